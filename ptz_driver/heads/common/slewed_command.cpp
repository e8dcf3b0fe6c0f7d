#include "ptz_driver/heads/common/slewed_command.hpp"

#include <algorithm>

namespace ptz::driver {

bool SlewedCommand::hold(const std::optional<PtzPose>& measured) {
  if (!measured) {
    target_.reset();
    return false;
  }
  // The command, not only the target: a command slewed back from where it ran ahead of the
  // head would drive the head on toward it meanwhile.
  target_ = commanded_ = *measured;
  started_ = true;
  return true;
}

std::optional<PtzPose> SlewedCommand::step(const std::optional<PtzPose>& measured,
                                           double period_s) {
  if (!target_ || !measured) return std::nullopt;
  if (!started_) {
    commanded_ = *measured;
    started_ = true;
  }
  const double step = max_rate_rad_s_ * period_s;
  commanded_.pan_rad += std::clamp(target_->pan_rad - commanded_.pan_rad, -step, step);
  commanded_.tilt_rad += std::clamp(target_->tilt_rad - commanded_.tilt_rad, -step, step);
  commanded_.zoom = target_->zoom;
  return commanded_;
}

}  // namespace ptz::driver
