#include "sim/scene/light.hpp"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/config.hpp"

namespace ptz::sim {
namespace {

// "[x, y, z]" as the config wrote it (a zero vector's error shows the value).
std::string text(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  return s.str();
}

// The keyframes' directions, `direction: [[x, y, z], ...]` (or one, `[x, y, z]`), each normalised.
std::vector<Eigen::Vector3d> readDirections(const cv::FileNode& node, const std::string& w) {
  const cv::FileNode list = readNode(node, "direction", w);
  const std::string path = fieldPath(w, "direction");
  if (!list.isSeq() || list.size() == 0) {
    throw ConfigError(path + ": must be a list of directions [x, y, z]");
  }
  const bool single = !list[0].isSeq();  // `direction: [x, y, z]`, one direction
  std::vector<cv::FileNode> items;
  if (single) {
    items.push_back(list);
  } else {
    for (const auto& item : list) items.push_back(item);
  }
  std::vector<Eigen::Vector3d> out;
  for (size_t i = 0; i < items.size(); ++i) {
    const std::string at = single ? path : path + "[" + std::to_string(i) + "]";
    const cv::FileNode& item = items[i];
    Eigen::Vector3d v;
    bool numbers = item.isSeq() && item.size() == 3;
    for (int k = 0; numbers && k < 3; ++k) {
      const cv::FileNode c = item[k];
      numbers = c.isReal() || c.isInt();
      if (numbers) v[k] = static_cast<double>(c);
      numbers = numbers && std::isfinite(v[k]) && std::abs(v[k]) < 1e6;
    }
    if (!numbers) throw ConfigError(at + ": must be [x, y, z], three finite numbers");
    // Toward the light: a zero vector points nowhere.
    if (!(v.norm() > 1e-9)) throw ConfigError(at + ": must not be zero, got " + text(v));
    out.push_back(v.normalized());
  }
  return out;
}

// A yes-or-no field: true or false (1 or 0).
bool readFlag(const cv::FileNode& node, const std::string& field, const std::string& w,
              bool fallback) {
  const cv::FileNode n = node[field];
  if (n.empty()) return fallback;
  if (n.isInt() && (static_cast<int>(n) == 0 || static_cast<int>(n) == 1)) {
    return static_cast<int>(n) == 1;
  }
  if (n.isString()) {
    const std::string v = static_cast<std::string>(n);
    if (v == "true") return true;
    if (v == "false") return false;
  }
  std::string got = n.isString() ? "'" + static_cast<std::string>(n) + "'" : "another value";
  if (n.isInt()) got = std::to_string(static_cast<int>(n));
  if (n.isReal()) got = std::to_string(static_cast<double>(n));
  throw ConfigError(fieldPath(w, field) + ": must be true or false, got " + got);
}

}  // namespace

const Eigen::Vector3d& Light::defaultToLight() {
  static const Eigen::Vector3d kToLight = Eigen::Vector3d(-0.3, -0.8, -0.5).normalized();
  return kToLight;
}

Eigen::Vector3d Light::toLightAt(double t_s) const {
  if (direction.empty()) return defaultToLight();
  const auto after = std::upper_bound(direction_s.begin(), direction_s.end(), t_s);
  if (after == direction_s.begin()) return direction.front();
  if (after == direction_s.end()) return direction.back();
  const size_t i = static_cast<size_t>(after - direction_s.begin());
  const double a = (t_s - direction_s[i - 1]) / (direction_s[i] - direction_s[i - 1]);
  // Never zero: neighbouring keyframes are not opposite (fromConfig).
  return ((1 - a) * direction[i - 1] + a * direction[i]).normalized();
}

bool Light::off() const {
  return brightness.empty() && (mains_hz <= 0 || flicker_depth <= 0) && vignetting <= 0 &&
         !tinted();
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
    if (tinted()) {
      cv::multiply(*bgr, cv::Scalar(gain * tint_bgr[0], gain * tint_bgr[1], gain * tint_bgr[2]),
                   *bgr);
    } else {
      bgr->convertTo(*bgr, CV_8U, gain);
    }
    return;
  }
  const double cx = (bgr->cols - 1) / 2.0, cy = (bgr->rows - 1) / 2.0;
  const double corner2 = cx * cx + cy * cy;
  for (int y = 0; y < bgr->rows; ++y) {
    cv::Vec3b* row = bgr->ptr<cv::Vec3b>(y);
    for (int x = 0; x < bgr->cols; ++x) {
      const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / corner2;
      const double g = gain * (1 - vignetting * r2);
      for (int k = 0; k < 3; ++k) row[x][k] = cv::saturate_cast<uchar>(row[x][k] * g * tint_bgr[k]);
    }
  }
}

double FirstOrderLag::step(double t_s, double time_constant_s) {
  const double dt_s = started_ ? std::max(0.0, t_s - last_t_s_) : 0;
  last_t_s_ = t_s;
  started_ = true;
  return 1 - std::exp(-dt_s / time_constant_s);
}

void AutoExposure::apply(const Light& light, double t_s, cv::Mat* bgr) {
  if (light.auto_exposure_target <= 0) return;
  if (gain_ != 1) bgr->convertTo(*bgr, CV_8U, gain_);
  const cv::Scalar mean = cv::mean(*bgr);
  const double grey = std::max(1.0, (mean[0] + mean[1] + mean[2]) / 3);
  const double wanted = std::clamp(gain_ * light.auto_exposure_target / grey,
                                   1 / light.auto_exposure_max_gain, light.auto_exposure_max_gain);
  gain_ += lag_.step(t_s, light.auto_exposure_time_constant_s) * (wanted - gain_);
}

void AutoWhiteBalance::apply(const Light& light, double t_s, cv::Mat* bgr) {
  const double tau_s = light.auto_white_balance_time_constant_s;
  if (tau_s <= 0) return;
  if (gain_b_ != 1 || gain_r_ != 1) cv::multiply(*bgr, cv::Scalar(gain_b_, 1, gain_r_), *bgr);
  // Grey world: the scene's mean taken as grey, so the mean blue and red should be its green.
  const cv::Scalar mean = cv::mean(*bgr);
  const double green = std::max(1.0, mean[1]);
  const double wanted_b = std::clamp(gain_b_ * green / std::max(1.0, mean[0]), kMinGain, kMaxGain);
  const double wanted_r = std::clamp(gain_r_ * green / std::max(1.0, mean[2]), kMinGain, kMaxGain);
  const double step = lag_.step(t_s, tau_s);
  gain_b_ += step * (wanted_b - gain_b_);
  gain_r_ += step * (wanted_r - gain_r_);
}

Light Light::fromConfig(const cv::FileNode& node, const std::string& where) {
  Light light;
  if (node.empty()) return light;
  const std::string w = where + ", light";
  if (!node.isMap()) throw ConfigError(w + ": must be a map");
  checkFields(node,
              {"brightness_s", "brightness", "mains_hz", "flicker_depth", "vignetting",
               "auto_exposure_target", "auto_exposure_time_constant_s", "auto_exposure_max_gain",
               "tint_bgr", "auto_white_balance_time_constant_s", "direction_s", "direction",
               "shadows", "shadow_depth"},
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
  if (!node["tint_bgr"].empty()) {
    const auto tint = readNumbers(node, "tint_bgr", 3, w, Range::between(0, 4));
    light.tint_bgr = {tint[0], tint[1], tint[2]};
  }
  light.auto_white_balance_time_constant_s =
      readDouble(node, "auto_white_balance_time_constant_s", w, 0.0, Range::between(0, 100));
  if (!node["direction"].empty() || !node["direction_s"].empty()) {
    light.direction = readDirections(node, w);
    // One direction needs no time: the light stays there.
    light.direction_s = light.direction.size() == 1 && node["direction_s"].empty()
                            ? std::vector<double>{0.0}
                            : readNumberList(node, "direction_s", w, Range::between(0, 1e6));
    if (light.direction.size() != light.direction_s.size()) {
      throw ConfigError(fieldPath(w, "direction") + ": " + std::to_string(light.direction.size()) +
                        " directions for " + std::to_string(light.direction_s.size()) +
                        " times in direction_s");
    }
    for (size_t i = 1; i < light.direction_s.size(); ++i) {
      if (!(light.direction_s[i] > light.direction_s[i - 1])) {
        throw ConfigError(fieldPath(w, "direction_s") + ": times must increase (" +
                          std::to_string(light.direction_s[i]) + " after " +
                          std::to_string(light.direction_s[i - 1]) + ")");
      }
      // Half-way between opposite directions the light would be nowhere.
      if (light.direction[i].dot(light.direction[i - 1]) < -0.999) {
        throw ConfigError(fieldPath(w, "direction") + "[" + std::to_string(i) +
                          "]: opposite to the one before (the way between is undefined; put a "
                          "keyframe between)");
      }
    }
  }
  light.shadows = readFlag(node, "shadows", w, false);
  light.shadow_depth = readDouble(node, "shadow_depth", w, 0.55, Range::between(0, 1));
  return light;
}

}  // namespace ptz::sim
