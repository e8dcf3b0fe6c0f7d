#include "ptz_driver/heads/pelco_d/pelco_model.hpp"

#include <algorithm>
#include <cmath>

#include "common/config.hpp"
#include "ptz_driver/heads/common/pan_tilt_range.hpp"

namespace ptz::driver {
namespace {
constexpr double kDeg = M_PI / 180;
constexpr int kTurn = 36000;  // hundredths of a degree

int toHead(double rad, double min_rad, double max_rad, int zero, int direction) {
  const long v = zero + direction * std::lround(std::clamp(rad, min_rad, max_rad) / kDeg * 100);
  return static_cast<int>(((v % kTurn) + kTurn) % kTurn);
}

double fromHead(int centideg, int zero, int direction) {
  int d = ((direction * (centideg - zero)) % kTurn + kTurn) % kTurn;  // 0..35999
  if (d > kTurn / 2) d -= kTurn;
  return d / 100.0 * kDeg;
}

int readDirection(const cv::FileNode& root, const std::string& field, const std::string& where) {
  const int d = readInt(root, field, where);
  if (d != 1 && d != -1) {
    throw ConfigError(fieldPath(where, field) + ": must be 1 or -1, got '" + std::to_string(d) +
                      "'");
  }
  return d;
}
}  // namespace

PelcoModel PelcoModel::load(const std::string& path) {
  const std::string where = "Pelco-D model file '" + path + "'";
  cv::FileStorage fs = openForRead(path, "Pelco-D model file");
  const cv::FileNode root = fs.root();
  checkFields(root,
              {"name", "pan_zero_centideg", "tilt_zero_centideg", "pan_direction", "tilt_direction",
               "pan_min_deg", "pan_max_deg", "tilt_min_deg", "tilt_max_deg", "zoom_positions",
               "zoom_ratios"},
              where);
  PelcoModel m;
  m.name = readString(root, "name", where);
  const Range centideg = Range::between(0, kTurn - 1);
  m.pan_zero_centideg = readInt(root, "pan_zero_centideg", where, centideg);
  m.tilt_zero_centideg = readInt(root, "tilt_zero_centideg", where, centideg);
  m.pan_direction = readDirection(root, "pan_direction", where);
  m.tilt_direction = readDirection(root, "tilt_direction", where);
  // Both ends within half a turn of zero, or the angle read back is ambiguous.
  const Range angle = Range::above(-180).andAtMost(180);
  const PanTiltRange range = readPanTiltRange(root, where, angle);
  m.pan_min_rad = range.pan_min_rad;
  m.pan_max_rad = range.pan_max_rad;
  m.tilt_min_rad = range.tilt_min_rad;
  m.tilt_max_rad = range.tilt_max_rad;
  m.zoom = ZoomTable::read(root, where);
  return m;
}

int PelcoModel::panCentideg(double pan_rad) const {
  return toHead(pan_rad, pan_min_rad, pan_max_rad, pan_zero_centideg, pan_direction);
}
int PelcoModel::tiltCentideg(double tilt_rad) const {
  return toHead(tilt_rad, tilt_min_rad, tilt_max_rad, tilt_zero_centideg, tilt_direction);
}
double PelcoModel::panRad(int centideg) const {
  return fromHead(centideg, pan_zero_centideg, pan_direction);
}
double PelcoModel::tiltRad(int centideg) const {
  return fromHead(centideg, tilt_zero_centideg, tilt_direction);
}

}  // namespace ptz::driver
