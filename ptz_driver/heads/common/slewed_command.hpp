// What ptz-driver commands one head: its target (a fresh setpoint, already within the limits)
// approached at most max_rate_rad_s in pan and tilt, starting from where the head is measured;
// and the deadman's hold, which commands the head to stop where it is measured. No I/O: the
// driver's tick sends what step() returns.
#pragma once

#include <optional>

#include "common/rig.hpp"  // PtzPose

namespace ptz::driver {

class SlewedCommand {
 public:
  explicit SlewedCommand(double max_rate_rad_s) : max_rate_rad_s_(max_rate_rad_s) {}

  // A fresh setpoint for this head.
  void setTarget(const PtzPose& target) { target_ = target; }
  // Deadman: the head is to stop where it is measured. False when its position is unknown:
  // there is no target any more and the caller stops the head by other means.
  bool hold(const std::optional<PtzPose>& measured);
  // The pose to command now, period_s after the last step; nullopt without a target or before
  // the head's position is known (the slew starts from where it is).
  std::optional<PtzPose> step(const std::optional<PtzPose>& measured, double period_s);

  bool hasTarget() const { return target_.has_value(); }
  const std::optional<PtzPose>& target() const { return target_; }

 private:
  double max_rate_rad_s_;
  std::optional<PtzPose> target_;
  PtzPose commanded_{};
  bool started_ = false;  // commanded_ is a command (else the next step starts from measured)
};

}  // namespace ptz::driver
