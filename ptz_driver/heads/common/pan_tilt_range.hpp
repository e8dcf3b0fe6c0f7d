// The pan and tilt range of a camera model file (VISCA, Pelco-D): both model loaders read it alike.
#pragma once

#include <opencv2/core.hpp>

#include <string>

#include "common/config.hpp"

namespace ptz::driver {

struct PanTiltRange {
  double pan_min_rad = 0, pan_max_rad = 0, tilt_min_rad = 0, tilt_max_rad = 0;
};

// pan_min_deg, pan_max_deg, tilt_min_deg, tilt_max_deg, each within angle_deg, each min below its
// max; errors name where, the field and the value.
PanTiltRange readPanTiltRange(const cv::FileNode& root, const std::string& where,
                              const Range& angle_deg);

}  // namespace ptz::driver
