#include "perception/detection/color_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "perception/detection/detector.hpp"

namespace ptz::perception {

double hueDifferenceDeg(double a_deg, double b_deg) {
  double d = std::fmod(a_deg - b_deg, 360.0);
  if (d <= -180) d += 360;
  if (d > 180) d -= 360;
  return d;
}

double hueWindowHalfwidthDeg(double hue_min_deg, double hue_max_deg) {
  const double width =
      hue_min_deg <= hue_max_deg ? hue_max_deg - hue_min_deg : 360 - hue_min_deg + hue_max_deg;
  return width / 2;
}

double hueWindowCentreDeg(double hue_min_deg, double hue_max_deg) {
  return std::fmod(hue_min_deg + hueWindowHalfwidthDeg(hue_min_deg, hue_max_deg), 360.0);
}

RegionColour mergeColours(const RegionColour& a, const RegionColour& b) {
  if (a.pixels <= 0) return b;
  if (b.pixels <= 0) return a;
  const double wa = static_cast<double>(a.pixels) / (a.pixels + b.pixels), wb = 1 - wa;
  // Pooled: each side's spread plus its mean's distance from the pooled mean.
  const auto pooled = [&](double ma, double sa, double mb, double sb, double m) {
    return std::sqrt(wa * (sa * sa + (ma - m) * (ma - m)) + wb * (sb * sb + (mb - m) * (mb - m)));
  };
  RegionColour m;
  m.pixels = a.pixels + b.pixels;
  m.hue_offset_deg = wa * a.hue_offset_deg + wb * b.hue_offset_deg;
  m.hue_sigma_deg = pooled(a.hue_offset_deg, a.hue_sigma_deg, b.hue_offset_deg, b.hue_sigma_deg,
                           m.hue_offset_deg);
  m.saturation = wa * a.saturation + wb * b.saturation;
  m.saturation_sigma =
      pooled(a.saturation, a.saturation_sigma, b.saturation, b.saturation_sigma, m.saturation);
  m.intensity = wa * a.intensity + wb * b.intensity;
  return m;
}

bool ColorModel::recent(double t_s, const ColorAdaptParams& p) const {
  return updates_ > 0 && t_s >= last_s_ && t_s - last_s_ <= p.follow_forget_s;
}

void ColorModel::learn(const RegionColour& c, double t_s, const ColorAdaptParams& p) {
  if (c.pixels <= 0) return;
  if (!recent(t_s, p)) updates_ = 0;  // a new object, maybe in another light
  if (updates_ == 0) {
    hue_offset_deg_ = c.hue_offset_deg;
    hue_sigma_deg_ = c.hue_sigma_deg;
  } else {
    hue_offset_deg_ += p.follow_learning_rate * (c.hue_offset_deg - hue_offset_deg_);
    hue_sigma_deg_ += p.follow_learning_rate * (c.hue_sigma_deg - hue_sigma_deg_);
  }
  updates_ = std::min(updates_ + 1, 1 << 20);  // enough to say "learned"; never overflows
  last_s_ = t_s;
  last_ = c;
}

HueGate ColorModel::gate(double t_s, const ColorAdaptParams& p) const {
  HueGate g;
  if (!p.follow || updates_ < p.follow_min_updates || !recent(t_s, p)) return g;
  g.active = true;
  g.offset_deg = hue_offset_deg_;
  g.halfwidth_deg = std::max(p.follow_min_halfwidth_deg, p.follow_sigmas * hue_sigma_deg_);
  return g;
}

std::string ColorModel::outOfRange(const ColorClass& c, const ColorAdaptParams& p) const {
  if (updates_ == 0) return "";
  char text[160];
  const bool whole_circle = c.hue_min_deg <= 0 && c.hue_max_deg >= 360;
  const double halfwidth = hueWindowHalfwidthDeg(c.hue_min_deg, c.hue_max_deg);
  // The object's hue band as the gate takes it: the window cuts off part of the object.
  const double band_deg =
      std::max(p.follow_min_halfwidth_deg, p.follow_sigmas * last_.hue_sigma_deg);
  if (!whole_circle && std::abs(last_.hue_offset_deg) + band_deg > halfwidth) {
    const double centre = hueWindowCentreDeg(c.hue_min_deg, c.hue_max_deg);
    const double hue = std::fmod(centre + last_.hue_offset_deg + 360, 360.0);
    std::snprintf(text, sizeof text, "hue %.1f +- %.1f deg reaches the window %.0f .. %.0f", hue,
                  band_deg, c.hue_min_deg, c.hue_max_deg);
    return text;
  }
  // (A saturation_max of 1 is no limit: no colour is beyond it.)
  if (last_.saturation - 2 * last_.saturation_sigma < c.saturation_min ||
      (c.saturation_max < 1 && last_.saturation + 2 * last_.saturation_sigma > c.saturation_max)) {
    std::snprintf(text, sizeof text, "saturation %.2f +- %.2f reaches the limits %.2f .. %.2f",
                  last_.saturation, 2 * last_.saturation_sigma, c.saturation_min, c.saturation_max);
    return text;
  }
  // Relative intensity follows the light down to its floor; otherwise intensity_min is the limit.
  const double darkest =
      p.intensity_min_fraction > 0 ? p.intensity_floor / p.intensity_min_fraction : c.intensity_min;
  if (last_.intensity < 1.5 * darkest) {
    std::snprintf(text, sizeof text, "mean intensity %.0f near its limit %.0f", last_.intensity,
                  darkest);
    return text;
  }
  return "";
}

HueGroups twoHueGroups(const std::vector<uint8_t>& levels, double levels_per_deg,
                       double min_pixels) {
  HueGroups g;
  const double least = std::max(1.0, min_pixels);
  if (static_cast<double>(levels.size()) < 2 * least) return g;
  const cv::Mat all(1, static_cast<int>(levels.size()), CV_8U, const_cast<uint8_t*>(levels.data()));
  cv::Mat upper;
  g.threshold = cv::threshold(all, upper, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  const int upper_count = cv::countNonZero(upper);
  if (upper_count < least || static_cast<double>(levels.size()) - upper_count < least) return g;
  cv::Scalar lower_mean, lower_sd, upper_mean, upper_sd;
  cv::meanStdDev(all, lower_mean, lower_sd, upper == 0);
  cv::meanStdDev(all, upper_mean, upper_sd, upper);
  g.gap_deg = (upper_mean[0] - lower_mean[0]) / levels_per_deg;
  g.pooled_sigma_deg =
      std::sqrt((lower_sd[0] * lower_sd[0] + upper_sd[0] * upper_sd[0]) / 2) / levels_per_deg;
  // The histogram, each bin the mean of a degree's bins around it (the noise of few pixels a bin).
  std::vector<double> histogram(256, 0), smooth(256, 0);
  for (const uint8_t v : levels) histogram[v] += 1;
  const int half = std::max(0, static_cast<int>(std::lround(levels_per_deg / 2)));
  for (int i = 0; i < 256; ++i) {
    const int lo = std::max(0, i - half), hi = std::min(255, i + half);
    for (int k = lo; k <= hi; ++k) smooth[i] += histogram[k];
    smooth[i] /= hi - lo + 1;
  }
  const int t = static_cast<int>(g.threshold);
  const double lower_peak = *std::max_element(smooth.begin(), smooth.begin() + t + 1);
  const double upper_peak = *std::max_element(smooth.begin() + t + 1, smooth.end());
  const auto from = static_cast<ptrdiff_t>(std::lround(lower_mean[0]));
  const auto to = static_cast<ptrdiff_t>(std::lround(upper_mean[0]));
  const double valley = *std::min_element(smooth.begin() + from, smooth.begin() + to + 1);
  g.valley_fraction = valley / std::min(lower_peak, upper_peak);
  g.two = g.gap_deg >= HueGroups::kMinGapDeg &&
          g.gap_deg >= HueGroups::kMinSeparation * g.pooled_sigma_deg &&
          g.valley_fraction <= HueGroups::kMaxValleyFraction;
  return g;
}

}  // namespace ptz::perception
