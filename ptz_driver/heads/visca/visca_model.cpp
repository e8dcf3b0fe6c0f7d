#include "ptz_driver/heads/visca/visca_model.hpp"

#include <algorithm>
#include <cmath>

#include "common/config.hpp"
#include "ptz_driver/heads/common/pan_tilt_range.hpp"

namespace ptz::driver {

ViscaModel ViscaModel::load(const std::string& path) {
  const std::string where = "VISCA model file '" + path + "'";
  cv::FileStorage fs = openForRead(path, "VISCA model file");
  const cv::FileNode root = fs.root();
  checkFields(root,
              {"name", "pan_nibbles", "pan_units_per_deg", "tilt_units_per_deg", "pan_min_deg",
               "pan_max_deg", "tilt_min_deg", "tilt_max_deg", "pan_speed_max", "tilt_speed_max",
               "zoom_positions", "zoom_ratios"},
              where);
  ViscaModel m;
  m.name = readString(root, "name", where);
  m.pan_nibbles = readInt(root, "pan_nibbles", where, Range::between(4, 5));
  const double deg = M_PI / 180;
  const Range angle = Range::between(-360, 360);
  m.pan_units_per_rad = readDouble(root, "pan_units_per_deg", where, Range::above(0)) / deg;
  m.tilt_units_per_rad = readDouble(root, "tilt_units_per_deg", where, Range::above(0)) / deg;
  const PanTiltRange range = readPanTiltRange(root, where, angle);
  m.pan_min_rad = range.pan_min_rad;
  m.pan_max_rad = range.pan_max_rad;
  m.tilt_min_rad = range.tilt_min_rad;
  m.tilt_max_rad = range.tilt_max_rad;
  // Every position within the limits is spoken in the command's signed nibbles: pan's 4 or 5,
  // tilt's 4.
  const auto fits = [&](double rad, double units_per_rad, int nibbles, const char* field) {
    const double units = std::round(rad * units_per_rad), limit = std::ldexp(1.0, 4 * nibbles - 1);
    if (!(units >= -limit && units < limit)) {
      throw ConfigError(fieldPath(where, field) + ": " + std::to_string(rad / deg) + " deg is " +
                        std::to_string(units) + " units, beyond the " + std::to_string(nibbles) +
                        " nibbles of a VISCA position");
    }
  };
  fits(m.pan_min_rad, m.pan_units_per_rad, m.pan_nibbles, "pan_min_deg");
  fits(m.pan_max_rad, m.pan_units_per_rad, m.pan_nibbles, "pan_max_deg");
  fits(m.tilt_min_rad, m.tilt_units_per_rad, 4, "tilt_min_deg");
  fits(m.tilt_max_rad, m.tilt_units_per_rad, 4, "tilt_max_deg");
  // VISCA speeds are one byte, 1 up to the model's maximum.
  m.pan_speed_max = readInt(root, "pan_speed_max", where, Range::between(1, 127));
  m.tilt_speed_max = readInt(root, "tilt_speed_max", where, Range::between(1, 127));
  m.zoom = ZoomTable::read(root, where);
  return m;
}

int32_t ViscaModel::panUnits(double pan_rad) const {
  return static_cast<int32_t>(
      std::lround(std::clamp(pan_rad, pan_min_rad, pan_max_rad) * pan_units_per_rad));
}

int32_t ViscaModel::tiltUnits(double tilt_rad) const {
  return static_cast<int32_t>(
      std::lround(std::clamp(tilt_rad, tilt_min_rad, tilt_max_rad) * tilt_units_per_rad));
}

}  // namespace ptz::driver
