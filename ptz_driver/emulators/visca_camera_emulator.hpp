// A VISCA camera emulator: the camera side of the protocol, used by ptz-sim to expose its
// simulated heads as VISCA cameras and by the tests of the driver's transports.
#pragma once

#include <optional>
#include <vector>

#include "common/rig.hpp"  // PtzPose
#include "ptz_driver/heads/visca/visca.hpp"
#include "ptz_driver/heads/visca/visca_model.hpp"

namespace ptz::driver {

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
