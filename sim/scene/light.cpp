#include "sim/scene/light.hpp"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>

#include "common/config.hpp"

namespace ptz::sim {

bool Light::off() const {
  return brightness.empty() && (mains_hz <= 0 || flicker_depth <= 0) && vignetting <= 0;
}

double Light::gainAt(double t_s) const {
  double gain = 1;
  if (!brightness.empty()) {
    const auto after = std::upper_bound(brightness_s.begin(), brightness_s.end(), t_s);
    if (after == brightness_s.begin()) {
      gain = brightness.front();
    } else if (after == brightness_s.end()) {
      gain = brightness.back();
    } else {
      const size_t i = static_cast<size_t>(after - brightness_s.begin());
      const double a = (t_s - brightness_s[i - 1]) / (brightness_s[i] - brightness_s[i - 1]);
      gain = brightness[i - 1] + a * (brightness[i] - brightness[i - 1]);
    }
  }
  if (mains_hz > 0 && flicker_depth > 0) {
    // Full at the mains' peaks, down by the depth at their zero crossings.
    const double s = std::sin(2 * M_PI * mains_hz * t_s);
    gain *= 1 - flicker_depth * (1 - s * s);
  }
  return gain;
}

void Light::apply(double t_s, cv::Mat* bgr) const {
  if (off()) return;
  const double gain = gainAt(t_s);
  if (vignetting <= 0) {
    bgr->convertTo(*bgr, CV_8U, gain);
    return;
  }
  const double cx = (bgr->cols - 1) / 2.0, cy = (bgr->rows - 1) / 2.0;
  const double corner2 = cx * cx + cy * cy;
  for (int y = 0; y < bgr->rows; ++y) {
    cv::Vec3b* row = bgr->ptr<cv::Vec3b>(y);
    for (int x = 0; x < bgr->cols; ++x) {
      const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / corner2;
      const double g = gain * (1 - vignetting * r2);
      for (int k = 0; k < 3; ++k) row[x][k] = cv::saturate_cast<uchar>(row[x][k] * g);
    }
  }
}

void AutoExposure::apply(const Light& light, double t_s, cv::Mat* bgr) {
  if (light.auto_exposure_target <= 0) return;
  if (gain_ != 1) bgr->convertTo(*bgr, CV_8U, gain_);
  const cv::Scalar mean = cv::mean(*bgr);
  const double grey = std::max(1.0, (mean[0] + mean[1] + mean[2]) / 3);
  const double wanted = std::clamp(gain_ * light.auto_exposure_target / grey,
                                   1 / light.auto_exposure_max_gain, light.auto_exposure_max_gain);
  const double dt_s = started_ ? std::max(0.0, t_s - last_t_s_) : 0;
  gain_ += (1 - std::exp(-dt_s / light.auto_exposure_time_constant_s)) * (wanted - gain_);
  last_t_s_ = t_s;
  started_ = true;
}

Light Light::fromConfig(const cv::FileNode& node, const std::string& where) {
  Light light;
  if (node.empty()) return light;
  const std::string w = where + ", light";
  if (!node.isMap()) throw ConfigError(w + ": must be a map");
  checkFields(node,
              {"brightness_s", "brightness", "mains_hz", "flicker_depth", "vignetting",
               "auto_exposure_target", "auto_exposure_time_constant_s", "auto_exposure_max_gain"},
              w);
  if (!node["brightness"].empty() || !node["brightness_s"].empty()) {
    light.brightness_s = readNumberList(node, "brightness_s", w, Range::between(0, 1e6));
    light.brightness = readNumberList(node, "brightness", w, Range::between(0, 4));
    if (light.brightness.size() != light.brightness_s.size()) {
      throw ConfigError(w + ", brightness: " + std::to_string(light.brightness.size()) +
                        " values for " + std::to_string(light.brightness_s.size()) +
                        " times in brightness_s");
    }
    for (size_t i = 1; i < light.brightness_s.size(); ++i) {
      if (!(light.brightness_s[i] > light.brightness_s[i - 1])) {
        throw ConfigError(w + ", brightness_s: times must increase (" +
                          std::to_string(light.brightness_s[i]) + " after " +
                          std::to_string(light.brightness_s[i - 1]) + ")");
      }
    }
  }
  light.mains_hz = readDouble(node, "mains_hz", w, 0.0, Range::between(0, 1000));
  light.flicker_depth = readDouble(node, "flicker_depth", w, 0.0, Range::between(0, 1));
  light.vignetting = readDouble(node, "vignetting", w, 0.0, Range::between(0, 0.9));
  light.auto_exposure_target =
      readDouble(node, "auto_exposure_target", w, 0.0, Range::between(0, 255));
  light.auto_exposure_time_constant_s =
      readDouble(node, "auto_exposure_time_constant_s", w, 0.5, Range::between(0.001, 100));
  light.auto_exposure_max_gain =
      readDouble(node, "auto_exposure_max_gain", w, 8.0, Range::between(1, 64));
  return light;
}

}  // namespace ptz::sim
