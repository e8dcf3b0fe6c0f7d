#include "perception/detection/color_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

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

}  // namespace ptz::perception
