// The motors of the emulated heads (tests): the shared plant model (PtzPlant), head 0 its left,
// head 1 its right, each moved to a target as a command arrives. Times from 0.
#pragma once

#include <algorithm>
#include <array>

#include "common/plant.hpp"

namespace ptz::driver {

class EmulatedMotors {
 public:
  EmulatedMotors(const PtzPlant::Params& plant, const PtzPose& home)
      : plant_(plant, home, home), targets_{home, home} {}

  // Where head (0, 1) is at now_s (the plant advanced to then).
  PtzPose pose(int head, double now_s) {
    plant_.advanceTo(std::max(now_s, plant_.time()));
    return plant_.pose(head == 0 ? Side::kLeft : Side::kRight);
  }
  const PtzPose& target(int head) const { return targets_[static_cast<size_t>(head)]; }
  // From now_s on head drives to target (clamped to the plant's limits, as a head does).
  void moveTo(int head, const PtzPose& target, double now_s) {
    targets_[static_cast<size_t>(head)] = target;
    int clamped = 0, rejected = 0;
    plant_.command(std::max(now_s, plant_.time()), targets_[0], targets_[1], &clamped, &rejected);
  }

 private:
  PtzPlant plant_;
  std::array<PtzPose, 2> targets_;
};

}  // namespace ptz::driver
