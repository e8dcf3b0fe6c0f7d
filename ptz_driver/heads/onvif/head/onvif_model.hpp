// What differs between the ONVIF cameras ptz-sim pretends to be: a model file (config/onvif/),
// not code. The angle map: ONVIF's normalised generic spaces (pan, tilt -1..1, zoom 0..1) against
// the plant's radians and zoom ratio.
#pragma once

#include <string>
#include <vector>

namespace ptz::driver {

struct OnvifModel {
  std::string name, manufacturer, model;
  double pan_min_rad = 0, pan_max_rad = 0, tilt_min_rad = 0, tilt_max_rad = 0;
  // The speed of AbsoluteMove's Speed 1 and ContinuousMove's velocity 1.
  double pan_tilt_speed_max_rad_s = 1;
  // Normalised zoom 0..1 -> zoom ratio: increasing, same length, interpolated piecewise linearly
  // (monotonic, so invertible), non-linear as a real lens's.
  std::vector<double> zoom_normalised, zoom_ratios;
  // A cheap camera: GetStatus answers after status_delay_ms, AbsoluteMove ignores its Speed.
  bool cheap = false;
  double status_delay_ms = 0;
  // False: a camera without AbsoluteMove (no absolute spaces; ContinuousMove only).
  bool absolute_moves = true;

  // Throws ConfigError naming the file and the field.
  static OnvifModel load(const std::string& path);

  // Linear in each axis; normalised values are clamped to -1..1.
  double panRad(double x) const;
  double tiltRad(double y) const;
  double panNormalised(double pan_rad) const;
  double tiltNormalised(double tilt_rad) const;
  // Through the table, clamped to its ends.
  double zoomRatio(double zoom_normalised) const;
  double zoomNormalised(double zoom_ratio) const;
};

}  // namespace ptz::driver
