// The head end of a Pelco-D RS-485 bus, for tests: one or two heads with absolute positioning
// (0x4B/0x4D/0x4F), stopped by the stop frame, answering the position queries 0x51/0x53/0x55
// with 0x59/0x5B/0x5D when answers_queries (most cheap heads do not). Frames with a bad
// checksum are counted and ignored, as a head does. The motors are the shared plant model
// (PtzPlant; the first address is its left head, the second its right), so positions are
// real. Times are seconds from the emulator's start (0).
#pragma once

#include <array>
#include <vector>

#include "ptz_driver/emulators/emulated_motors.hpp"
#include "ptz_driver/heads/pelco_d/pelco_model.hpp"
#include "ptz_driver/io/bytes.hpp"

namespace ptz::driver {

class PelcoDBusEmulator {
 public:
  PelcoDBusEmulator(PelcoModel model, const PtzPlant::Params& plant, std::vector<int> addresses,
                    bool answers_queries, const PtzPose& home = {});

  // Bytes from the controller at now_s; returns what the heads send back.
  Bytes feed(const uint8_t* data, size_t size, double now_s);
  // Where head (0, 1) is at now_s.
  PtzPose pose(int head, double now_s) { return motors_.pose(head, now_s); }
  // Every well-formed frame received, in order, and the frames with a bad checksum.
  const std::vector<Bytes>& received() const { return received_; }
  int64_t badChecksums() const { return bad_checksums_; }
  // Every target a head was given: (head, pose after the frame), in order.
  const std::vector<std::pair<int, PtzPose>>& moves() const { return moves_; }

 private:
  Bytes handle(size_t head, const Bytes& frame, double now_s);

  PelcoModel model_;
  EmulatedMotors motors_;
  std::vector<int> addresses_;
  bool answers_queries_;
  Bytes partial_;
  std::vector<Bytes> received_;
  int64_t bad_checksums_ = 0;
  std::vector<std::pair<int, PtzPose>> moves_;
};

}  // namespace ptz::driver
