#include "ptz_driver/heads/common/pan_tilt_range.hpp"

#include <cmath>

namespace ptz::driver {

PanTiltRange readPanTiltRange(const cv::FileNode& root, const std::string& where,
                              const Range& angle_deg) {
  const double pan_min = readDouble(root, "pan_min_deg", where, angle_deg);
  const double pan_max = readDouble(root, "pan_max_deg", where, angle_deg);
  const double tilt_min = readDouble(root, "tilt_min_deg", where, angle_deg);
  const double tilt_max = readDouble(root, "tilt_max_deg", where, angle_deg);
  checkFieldOrder(pan_min, pan_max, where, "pan_min_deg", "pan_max_deg");
  checkFieldOrder(tilt_min, tilt_max, where, "tilt_min_deg", "tilt_max_deg");
  constexpr double kRadPerDeg = M_PI / 180;
  return {pan_min * kRadPerDeg, pan_max * kRadPerDeg, tilt_min * kRadPerDeg, tilt_max * kRadPerDeg};
}

}  // namespace ptz::driver
