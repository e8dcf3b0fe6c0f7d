// What differs between VISCA cameras (a model file, not code), and a VISCA camera emulator:
// the camera side of the protocol, used by ptz-sim to expose its simulated heads as VISCA
// cameras and by the tests of the driver's transports.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ptz/rig.hpp"  // PtzPose
#include "ptz_driver/visca.hpp"
#include "ptz_driver/zoom_table.hpp"

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

// Where a command told the camera to go.
struct ViscaTarget {
  std::optional<double> pan_rad, tilt_rad, zoom;
};

class ViscaCameraEmulator {
 public:
  ViscaCameraEmulator(ViscaModel model, int address)
      : model_(std::move(model)), address_(address) {}

  // One VISCA packet (header to terminator) while the camera is at `now`: the reply packets
  // (ACK and completion, an inquiry's answer, or an error), and in *target where to move.
  std::vector<Bytes> handle(const Bytes& packet, const PtzPose& now, ViscaTarget* target) const;
  const ViscaModel& model() const { return model_; }

 private:
  Bytes reply(std::initializer_list<uint8_t> body) const;

  ViscaModel model_;
  int address_;
};

}  // namespace ptz::driver
