#include "ptz_driver/heads/onvif/head/onvif_model.hpp"

#include <algorithm>
#include <cmath>

#include "common/config.hpp"
#include "ptz_driver/heads/common/pan_tilt_range.hpp"
#include "ptz_driver/heads/common/zoom_table.hpp"

namespace ptz::driver {

namespace {
double toRange(double x, double lo, double hi) {
  return lo + (std::clamp(x, -1.0, 1.0) + 1) / 2 * (hi - lo);
}
double fromRange(double v, double lo, double hi) {
  return std::clamp(2 * (v - lo) / (hi - lo) - 1, -1.0, 1.0);
}
}  // namespace

OnvifModel OnvifModel::load(const std::string& path) {
  const std::string where = "ONVIF model file '" + path + "'";
  cv::FileStorage fs = openForRead(path, "ONVIF model file");
  const cv::FileNode root = fs.root();
  checkFields(root,
              {"name", "manufacturer", "model", "pan_min_deg", "pan_max_deg", "tilt_min_deg",
               "tilt_max_deg", "pan_tilt_speed_max_deg_s", "zoom_normalised", "zoom_ratios",
               "cheap", "status_delay_ms", "absolute_moves"},
              where);
  OnvifModel m;
  m.name = readString(root, "name", where);
  m.manufacturer = readString(root, "manufacturer", where);
  m.model = readString(root, "model", where);
  const PanTiltRange range = readPanTiltRange(root, where, Range::between(-360, 360));
  m.pan_min_rad = range.pan_min_rad;
  m.pan_max_rad = range.pan_max_rad;
  m.tilt_min_rad = range.tilt_min_rad;
  m.tilt_max_rad = range.tilt_max_rad;
  m.pan_tilt_speed_max_rad_s =
      readDouble(root, "pan_tilt_speed_max_deg_s", where, Range::above(0)) * M_PI / 180;
  m.zoom_normalised = readIncreasing(root, "zoom_normalised", where, Range::between(0, 1));
  m.zoom_ratios = readIncreasing(root, "zoom_ratios", where, Range::above(0));
  if (m.zoom_normalised.size() != m.zoom_ratios.size()) {
    throw ConfigError(fieldPath(where, "zoom_ratios") + ": must have as many entries as " +
                      "zoom_normalised (" + std::to_string(m.zoom_normalised.size()) + "), got " +
                      std::to_string(m.zoom_ratios.size()));
  }
  if (m.zoom_normalised.front() != 0 || m.zoom_normalised.back() != 1) {
    throw ConfigError(fieldPath(where, "zoom_normalised") + ": must run from 0 to 1");
  }
  m.cheap = readDouble(root, "cheap", where, 0.0, Range::between(0, 1)) != 0;
  m.status_delay_ms = readDouble(root, "status_delay_ms", where, 0.0, Range::between(0, 10000));
  m.absolute_moves = readDouble(root, "absolute_moves", where, 1.0, Range::between(0, 1)) != 0;
  return m;
}

double OnvifModel::panRad(double x) const {
  return toRange(x, pan_min_rad, pan_max_rad);
}
double OnvifModel::tiltRad(double y) const {
  return toRange(y, tilt_min_rad, tilt_max_rad);
}
double OnvifModel::panNormalised(double pan_rad) const {
  return fromRange(pan_rad, pan_min_rad, pan_max_rad);
}
double OnvifModel::tiltNormalised(double tilt_rad) const {
  return fromRange(tilt_rad, tilt_min_rad, tilt_max_rad);
}
double OnvifModel::zoomRatio(double zoom_normalised) const {
  return interpolate(this->zoom_normalised, zoom_ratios, zoom_normalised);
}
double OnvifModel::zoomNormalised(double zoom_ratio) const {
  return interpolate(zoom_ratios, zoom_normalised, zoom_ratio);
}

}  // namespace ptz::driver
