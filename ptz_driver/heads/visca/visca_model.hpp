// What differs between VISCA cameras: a model file, not code.
#pragma once

#include <string>
#include <vector>

#include "ptz_driver/heads/common/zoom_table.hpp"
#include "ptz_driver/heads/visca/visca.hpp"

namespace ptz::driver {

struct ViscaModel {
  std::string name;
  int pan_nibbles = 4;
  double pan_units_per_rad = 0, tilt_units_per_rad = 0;
  double pan_min_rad = 0, pan_max_rad = 0, tilt_min_rad = 0, tilt_max_rad = 0;
  int pan_speed_max = 24, tilt_speed_max = 20;
  ZoomTable zoom;

  // Throws ConfigError naming the file and the field.
  static ViscaModel load(const std::string& path);
  int32_t panUnits(double pan_rad) const;
  int32_t tiltUnits(double tilt_rad) const;
  double panRad(int32_t units) const { return units / pan_units_per_rad; }
  double tiltRad(int32_t units) const { return units / tilt_units_per_rad; }
  int zoomPosition(double ratio) const { return zoom.position(ratio); }
  double zoomRatio(int position) const { return zoom.ratio(position); }
};

}  // namespace ptz::driver
