// The camera end of a serial VISCA line, for tests: a daisy chain of one or two cameras as they
// answer. Address Set numbers them (and comes back with the next free address), IF_Clear comes
// back round; each camera (a ViscaCameraEmulator) runs commands in two sockets: ACK y0 4z FF,
// then the completion y0 5z FF after completion_delay_s (held while it is negative), and a
// command while both sockets are busy gets "command buffer full" (y0 60 03 FF). Inquiries are
// answered from where its motors are: the shared plant model (PtzPlant; camera 1 is its left
// head, camera 2 its right), so positions are real. A packet for an address nobody has comes
// back round the chain unchanged. Times are seconds from the emulator's start (0).
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "ptz_driver/emulators/emulated_motors.hpp"
#include "ptz_driver/emulators/visca_camera_emulator.hpp"

namespace ptz::driver {

class ViscaChainEmulator {
 public:
  ViscaChainEmulator(const ViscaModel& model, const PtzPlant::Params& plant, int cameras,
                     const PtzPose& home = {});

  // Bytes from the controller at now_s; returns what the chain sends back (replies, then the
  // completions due by now_s).
  Bytes feed(const uint8_t* data, size_t size, double now_s);
  // Completions due by now_s (and nothing else).
  Bytes poll(double now_s);
  // Completions after delay_s; negative: held until releaseCompletion.
  void setCompletionDelay(double delay_s) { completion_delay_s_ = delay_s; }
  // Completes the oldest running command of camera (0, 1); its completion bytes, if any.
  Bytes releaseCompletion(int camera);
  // A silent chain records what it gets and answers nothing (a camera switched off).
  void setSilent(bool silent) { silent_ = silent; }

  // Where camera (0, 1) is at now_s (the plant advanced to then).
  PtzPose pose(int camera, double now_s) { return motors_.pose(camera, now_s); }
  int address(int camera) const { return cameras_[static_cast<size_t>(camera)].address; }
  // Every packet from the controller, in order.
  const std::vector<Bytes>& received() const { return received_; }
  // Every move a camera was told to make: (camera, target), in order.
  const std::vector<std::pair<int, ViscaTarget>>& moves() const { return moves_; }

 private:
  struct Running {
    int socket;
    double done_s;  // < 0: held
  };
  struct Camera {
    int address = 0;  // 0 until Address Set
    std::vector<Running> running;
  };
  Bytes handle(const Bytes& packet, double now_s);
  Bytes handleCommand(size_t camera, const Bytes& packet, double now_s);
  Bytes completion(size_t camera, int socket) const;

  ViscaModel model_;
  EmulatedMotors motors_;
  std::vector<Camera> cameras_;
  double completion_delay_s_ = 0;
  bool silent_ = false;
  Bytes partial_;
  std::vector<Bytes> received_;
  std::vector<std::pair<int, ViscaTarget>> moves_;
};

}  // namespace ptz::driver
