#include "ptz_driver/heads/visca/visca_model.hpp"

#include <algorithm>
#include <cmath>

#include "common/config.hpp"

namespace ptz::driver {

ViscaModel ViscaModel::load(const std::string& path) {
  const std::string where = "VISCA model file '" + path + "'";
  cv::FileStorage fs = openForRead(path, "VISCA model file");
  const cv::FileNode root = fs.root();
  ViscaModel m;
  m.name = readString(root, "name", where);
  m.pan_nibbles = readInt(root, "pan_nibbles", where);
  if (m.pan_nibbles != 4 && m.pan_nibbles != 5) {
    throw ConfigError(where + ": field 'pan_nibbles' must be 4 or 5");
  }
  const double deg = M_PI / 180;
  m.pan_units_per_rad = readDouble(root, "pan_units_per_deg", where) / deg;
  m.tilt_units_per_rad = readDouble(root, "tilt_units_per_deg", where) / deg;
  m.pan_min_rad = readDouble(root, "pan_min_deg", where) * deg;
  m.pan_max_rad = readDouble(root, "pan_max_deg", where) * deg;
  m.tilt_min_rad = readDouble(root, "tilt_min_deg", where) * deg;
  m.tilt_max_rad = readDouble(root, "tilt_max_deg", where) * deg;
  m.pan_speed_max = readInt(root, "pan_speed_max", where);
  m.tilt_speed_max = readInt(root, "tilt_speed_max", where);
  m.zoom = ZoomTable::read(root, where);
  if (!(m.pan_units_per_rad > 0) || !(m.tilt_units_per_rad > 0) || m.pan_min_rad >= m.pan_max_rad ||
      m.tilt_min_rad >= m.tilt_max_rad) {
    throw ConfigError(where + ": units per degree must be > 0 and each min below its max");
  }
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
