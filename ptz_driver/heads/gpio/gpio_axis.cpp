#include "ptz_driver/heads/gpio/gpio_axis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ptz::driver {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
// A switch bounces for some milliseconds as it opens: at homing speed well under this.
constexpr double kSwitchClearRad = 0.01;
// Counts against the drive beyond what backlash and noise give: the motor or encoder is wrong.
constexpr int64_t kWrongWayCounts = 10;

std::string rad(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}
}  // namespace

GpioAxis::GpioAxis(AxisConfig config, GpioLines& lines)
    : config_(std::move(config)), lines_(lines) {
  const AxisLines& l = config_.lines;
  const std::string& p = config_.param_prefix;
  lines_.requestOutput(l.dir, p + "dir_line");
  if (l.dir2 >= 0) lines_.requestOutput(l.dir2, p + "dir2_line");
  lines_.requestOutput(l.enable, p + "enable_line");
  lines_.requestEvents(l.encoder_a, Bias::kAsIs, p + "encoder_a_line");
  lines_.requestEvents(l.encoder_b, Bias::kAsIs, p + "encoder_b_line");
  lines_.requestEvents(l.limit_min, Bias::kPullUp, p + "limit_min_line");
  lines_.requestEvents(l.limit_max, Bias::kPullUp, p + "limit_max_line");
  decoder_.reset(lines_.get(l.encoder_a), lines_.get(l.encoder_b));
  drive(false, false);
}

void GpioAxis::startHoming(double now_s) {
  homed_ = false;
  switch_seen_ = false;
  error_.clear();
  homing_start_s_ = now_s;
  min_closed_ = !lines_.get(config_.lines.limit_min);
  max_closed_ = !lines_.get(config_.lines.limit_max);
  target_rad_ = rawRad();
  ramp_ = true;
  // Sitting on the min switch: off it first, so that the reference is always the closing edge.
  if (min_closed_) {
    state_ = State::kBackoff;
    goal_rad_ = kInf;
    phase_start_raw_ = rawRad();
  } else {
    seek(now_s);
  }
}

void GpioAxis::seek(double now_s) {
  state_ = State::kSeek;
  homing_start_s_ = now_s;
  goal_rad_ = -kInf;
  phase_start_raw_ = rawRad();
  // On the max switch (coasted onto it, or turned there by hand): toward min is away from it.
  leaving_max_ = max_closed_;
  max_opened_ = false;
}

void GpioAxis::setTarget(double target_rad) {
  if (!homed_ || state_ == State::kFault || !std::isfinite(target_rad)) return;
  state_ = State::kReady;
  target_rad_ = std::clamp(target_rad, config_.soft_min_rad, config_.soft_max_rad);
  ramp_ = false;
}

void GpioAxis::stop() {
  if (state_ == State::kBackoff || state_ == State::kSeek) {
    state_ = State::kIdle;
    error_ = config_.name + ": homing interrupted by a stop; the axis is not homed (restart)";
  } else if (state_ == State::kReady) {
    state_ = State::kStopped;
  }
  duty_ = 0;
  drive(false, false);
}

bool GpioAxis::handle(const LineEvent& e) {
  const AxisLines& l = config_.lines;
  if (e.line == l.encoder_a || e.line == l.encoder_b) {
    decoder_.edge(e.line == l.encoder_a ? 0 : 1, e.rising, e.time_s);
  } else if (e.line == l.limit_min) {
    // The first closing edge of the seek is the homing reference, exact to the count.
    if (!e.rising && state_ == State::kSeek && !switch_seen_ && e.time_s >= homing_start_s_) {
      switch_seen_ = true;
      switch_count_ = decoder_.count();
    }
  } else if (e.line != l.limit_max) {
    return false;
  }
  return true;
}

double GpioAxis::step(double now_s) {
  const double period_s = 1.0 / config_.pwm_hz;
  if (!started_) {
    started_ = true;
    period_start_s_ = pulse_start_s_ = next_control_s_ = speed_ref_s_ = now_s;
  }
  min_closed_ = !lines_.get(config_.lines.limit_min);
  max_closed_ = !lines_.get(config_.lines.limit_max);
  if (now_s >= next_control_s_) {
    control(now_s);
    next_control_s_ += 1.0 / config_.control_hz;
    if (next_control_s_ <= now_s) next_control_s_ = now_s + 1.0 / config_.control_hz;
  } else {
    duty_ = limitDuty(duty_);  // switches and soft limits act at every PWM edge
  }
  if (now_s >= period_start_s_ + period_s) {
    period_start_s_ += period_s;
    if (period_start_s_ + period_s <= now_s) period_start_s_ = now_s;  // fell behind: no burst
    // A late wake-up delays the pulse but keeps its width (short pulses would be lost).
    pulse_start_s_ = now_s;
  }
  on_until_s_ = pulse_start_s_ + std::abs(duty_) * period_s;
  const bool on = duty_ != 0 && now_s < on_until_s_;
  drive(on, duty_ > 0);
  double next_s = std::min(next_control_s_, period_start_s_ + period_s);
  if (on) next_s = std::min(next_s, on_until_s_);
  return next_s;
}

void GpioAxis::control(double now_s) {
  updateSpeed(now_s);
  const double dt_s = 1.0 / config_.control_hz;
  if (ramp_) {
    const double step = config_.homing_speed_rad_s * dt_s;
    target_rad_ += std::clamp(goal_rad_ - target_rad_, -step, step);
    if (target_rad_ == goal_rad_) ramp_ = false;
  }
  const bool homing = state_ == State::kBackoff || state_ == State::kSeek;
  if (homing && now_s - homing_start_s_ > config_.homing_timeout_s) {
    char why[160];
    std::snprintf(why, sizeof why,
                  "homing timed out after %g s: the min limit switch (line %d) never closed",
                  config_.homing_timeout_s, config_.lines.limit_min);
    return fault(why);
  }
  if (homing && std::abs(target_rad_ - rawRad()) > config_.homing_max_lag_rad) return faultLag();
  if (homing && max_closed_ && min_closed_)
    return fault("both limit switches read closed: check their wiring");
  if (state_ == State::kBackoff) {
    if (max_closed_) return fault("both limit switches read closed: check their wiring");
    if (!min_closed_) seek(now_s);  // off the switch: now seek it
  } else if (state_ == State::kSeek) {
    if (leaving_max_) {
      const double span_rad = config_.max_switch_rad - config_.min_switch_rad;
      if (!max_closed_ && !max_opened_) {
        max_opened_ = true;
        max_open_raw_ = rawRad();
      }
      if (max_opened_ && !max_closed_ && rawRad() <= max_open_raw_ - kSwitchClearRad) {
        leaving_max_ = false;  // off it: from now on its closing is an edge
      } else if (max_closed_ && phase_start_raw_ - rawRad() > span_rad) {
        return fault("the max limit switch still reads closed after " + rad(span_rad) +
                     " rad toward min (the distance between the switches): the motor turns the "
                     "wrong way and so does the encoder (swap the motor's leads and the "
                     "encoder's A and B lines), or the switch is stuck closed (check its wiring)");
      }
    } else if (max_closed_) {
      return fault(
          "the max limit switch closed while homing toward min: the motor turns the "
          "wrong way (swap its leads)");
    }
    if (switch_seen_ || min_closed_) {
      const int64_t at = switch_seen_ ? switch_count_ : decoder_.count();
      zero_count_ = at - std::llround(config_.min_switch_rad * config_.counts_per_rad);
      homed_ = true;
      state_ = State::kReady;
      target_rad_ = positionRad();  // from the switch to 0 at homing speed
      goal_rad_ = std::clamp(0.0, config_.soft_min_rad, config_.soft_max_rad);
      ramp_ = true;
    }
  }
  if (state_ != State::kReady && !homing) {
    duty_ = 0;
    return;
  }
  const double error_rad = target_rad_ - (homed_ ? positionRad() : rawRad());
  double u = 0;
  if (std::abs(error_rad) > config_.deadband_rad) {
    u = config_.kp_duty_per_rad * error_rad - config_.kd_duty_s_per_rad * speed_rad_s_;
    if (u != 0) u = std::copysign(std::min(config_.max_duty, config_.min_duty + std::abs(u)), u);
  }
  duty_ = limitDuty(u);
}

// Behind the homing ramp: counts that went against the drive say which way round it is wired.
void GpioAxis::faultLag() {
  const bool up = state_ == State::kBackoff;
  const double moved_rad = (rawRad() - phase_start_raw_) * (up ? 1 : -1);
  if (moved_rad < -kWrongWayCounts / config_.counts_per_rad) {
    return fault(std::string("homing, the encoder counts toward ") + (up ? "min" : "max") +
                 " when the motor is driven toward " + (up ? "max" : "min") +
                 ": the motor turns the wrong way (swap its leads) or the encoder counts the "
                 "wrong way (swap its A and B lines)");
  }
  fault("does not follow the homing ramp (more than " + rad(config_.homing_max_lag_rad) +
        " rad behind it, having moved " + rad(moved_rad) + " rad toward " + (up ? "max" : "min") +
        "): is the motor powered and free to turn, and its encoder connected?");
}

// The speed from the times of the encoder's edges (exact at constant speed, not quantised by
// the control period); without an edge it is at most one count over the time since the last.
void GpioAxis::updateSpeed(double now_s) {
  const int64_t count = decoder_.count();
  const double edge_s = decoder_.lastEdgeS();
  if (count != speed_ref_count_ && edge_s > speed_ref_s_) {
    speed_rad_s_ = (count - speed_ref_count_) / config_.counts_per_rad / (edge_s - speed_ref_s_);
    speed_ref_count_ = count;
    speed_ref_s_ = edge_s;
  } else if (count == speed_ref_count_ && now_s > speed_ref_s_) {
    const double bound = 1.0 / config_.counts_per_rad / (now_s - speed_ref_s_);
    speed_rad_s_ = std::clamp(speed_rad_s_, -bound, bound);
  }
}

// No drive toward a closed switch, nor (once homed) beyond a soft limit; away is always allowed.
double GpioAxis::limitDuty(double duty) {
  const bool at_min = min_closed_ || (homed_ && positionRad() <= config_.soft_min_rad);
  const bool at_max = max_closed_ || (homed_ && positionRad() >= config_.soft_max_rad);
  if ((duty < 0 && at_min) || (duty > 0 && at_max)) {
    ++limit_blocks_;
    return 0;
  }
  return duty;
}

void GpioAxis::fault(const std::string& why) {
  state_ = State::kFault;
  homed_ = false;
  error_ = config_.name + ": " + why;
  duty_ = 0;
  drive(false, false);
}

// Only what changed is written (each write is a system call).
void GpioAxis::drive(bool on, bool positive) {
  const bool moving =
      state_ == State::kReady || state_ == State::kBackoff || state_ == State::kSeek;
  // Direction: 1 toward max, 0 toward min, kBothLow stopped (enable and both direction lines
  // low: the bridge brakes or coasts, as it is made). Off within a PWM period keeps it.
  constexpr int kBothLow = 2;
  const int dir = !moving ? kBothLow : on ? (positive ? 1 : 0) : out_dir_;
  const int enable = moving && on ? 1 : 0;
  if (enable == 0 && out_enable_ != 0) lines_.set(config_.lines.enable, false);
  if (dir >= 0 && dir != out_dir_) {
    lines_.set(config_.lines.dir, dir == 1);
    if (config_.lines.dir2 >= 0) lines_.set(config_.lines.dir2, dir == 0);
    out_dir_ = dir;
  }
  if (enable == 1 && out_enable_ != 1) lines_.set(config_.lines.enable, true);
  out_enable_ = enable;
}

}  // namespace ptz::driver
