// What differs between Pelco-D heads with absolute positioning (a model file, e.g.
// config/pelco_d/generic.yaml): how the head's angles (0x4B/0x4D set and 0x59/0x5B report pan
// and tilt in hundredths of a degree, 0..35999) map onto the project's pan_rad and tilt_rad
// (0 = home, pan > 0 turns right, tilt > 0 up), the head's range, and zoom position -> ratio.
//   head_centideg = (zero_centideg + direction * project_deg * 100) mod 36000
// and back, the difference to zero wrapped into (-180, 180] degrees.
#pragma once

#include <string>

#include "ptz_driver/heads/common/zoom_table.hpp"

namespace ptz::driver {

struct PelcoModel {
  std::string name;
  int pan_zero_centideg = 0, tilt_zero_centideg = 0;
  int pan_direction = 1, tilt_direction = -1;
  double pan_min_rad = 0, pan_max_rad = 0, tilt_min_rad = 0, tilt_max_rad = 0;
  ZoomTable zoom;

  // Throws ConfigError naming the file and the field.
  static PelcoModel load(const std::string& path);
  // Clamped to the head's range.
  int panCentideg(double pan_rad) const;
  int tiltCentideg(double tilt_rad) const;
  double panRad(int centideg) const;
  double tiltRad(int centideg) const;
};

}  // namespace ptz::driver
