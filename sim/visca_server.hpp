// ptz-sim's heads as VISCA-over-IP cameras on 127.0.0.1 (left at port, right at port + 1), so
// the real ptz-driver drives the simulated motors: absolute pan-tilt and zoom commands become
// setpoints of the PT1 + dead-time plant (the commanded speed is not modelled: the plant's own
// lag and rate limits are the motion), inquiries are answered from the plant's state.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "common/rig.hpp"
#include "ptz_driver/emulators/visca_camera_emulator.hpp"
#include "ptz_driver/io/udp.hpp"
#include "sim/sim_run.hpp"

namespace ptz::sim {

class ViscaServer {
 public:
  ViscaServer(const driver::ViscaModel& model, const std::string& host, int first_port);

  // Serves every waiting datagram with the heads at `now`; moves *setpoints where commands
  // say. Returns whether a setpoint changed; counts what was malformed.
  bool serve(const std::array<PtzPose, 2>& now, std::array<PtzPose, 2>* setpoints);
  int fd(Side side) const { return sockets_[static_cast<size_t>(side)]->fd(); }
  int64_t malformed() const { return malformed_; }
  int64_t packets() const { return packets_; }

 private:
  std::array<std::unique_ptr<driver::UdpSocket>, 2> sockets_;
  std::array<driver::ViscaCameraEmulator, 2> cameras_;
  int64_t malformed_ = 0, packets_ = 0;
};

// The two cameras on 127.0.0.1 on a thread of their own, as real ones answer while they stream:
// every datagram with the run's motors at the moment it arrives.
class ViscaCameras {
 public:
  ViscaCameras(const driver::ViscaModel& model, int first_port, SimRun* run);
  ~ViscaCameras() { stop(); }
  void start();
  void stop();
  int64_t packets() const { return packets_; }
  int64_t malformed() const { return malformed_; }
  int64_t setpointsApplied() const { return setpoints_applied_; }

 private:
  void serve();

  ViscaServer server_;
  SimRun* run_;
  std::array<PtzPose, 2> setpoints_{PtzPose{0, 0, 1}, PtzPose{0, 0, 1}};
  std::thread thread_;
  std::atomic<bool> quit_{false};
  std::atomic<int64_t> packets_{0}, malformed_{0}, setpoints_applied_{0};
};

}  // namespace ptz::sim
