#include "control/controller/controller.hpp"

#include <algorithm>
#include <cmath>

#include "control/controller/pointing.hpp"

namespace ptz::control {
namespace {

double clampAxis(double v, const AxisParams& a) {
  return std::clamp(v, a.min_position, a.max_position);
}

double slew(double from, double to, double max_step) {
  return from + std::clamp(to - from, -max_step, max_step);
}

std::array<SmithPredictor, 4> makeSmith(const ControllerParams& p) {
  auto axis = [&](int a) {
    SmithParams s;
    s.model = p.limits.axis[a];
    s.model.dead_time_s += p.smith_extra_delay_s;
    s.correction_filter_s = p.smith_filter_s;
    return SmithPredictor(s);
  };
  return {axis(0), axis(1), axis(0), axis(1)};
}

}  // namespace

Controller::Controller(StereoRig rig, ControllerParams params)
    : rig_(std::move(rig)), p_(std::move(params)), kalman_(p_.kalman), smith_(makeSmith(p_)) {}

bool Controller::plausible(const Observation& o) const {
  if (!o.position_head_m.allFinite() || !std::isfinite(o.radius_m)) return false;
  const double range = o.position_head_m.norm();
  return range >= p_.min_range_m && range <= p_.max_range_m && o.position_head_m.z() > 0;
}

double Controller::zoomFor(Side side, const Observation& o, const PtzPose& at_capture) const {
  const double current = setpoint_[static_cast<int>(side)].zoom;
  if (p_.zoom_mode != "size" || o.radius_m <= 0) return current;
  Eigen::Matrix3d R;
  Eigen::Vector3d c;
  rig_.cameraPose(side, at_capture.pan_rad, at_capture.tilt_rad, &R, &c);
  const double range = (o.position_head_m - c).norm();
  const double fx = p_.target_radius_px * range / o.radius_m;
  return std::min(zoomForFocalLength(rig_.camera(side), fx), p_.max_zoom);
}

PtzPose Controller::desired(Side side, const Observation& o, const PtzPose& at_capture, double dt) {
  const int i = static_cast<int>(side);
  const CameraSpec& spec = rig_.camera(side);
  PtzPose goal = setpoint_[i];
  // Zoom first: the pan/tilt that centre the object hardly depend on it.
  goal.zoom = zoomFor(side, o, at_capture);
  double pan = 0, tilt = 0;
  if (!aimAt(rig_, side, o.position_head_m, goal.zoom, imageCentre(spec), &pan, &tilt)) {
    return setpoint_[i];
  }
  if (p_.mode == "paper") {
    goal.pan_rad = p_.paper_gain * (pan - at_capture.pan_rad);
    goal.tilt_rad = p_.paper_gain * (tilt - at_capture.tilt_rad);
    return goal;
  }
  // Track: the filtered rate of theta* times the lead.
  const Eigen::Vector2d theta(pan, tilt);
  if (tracking_ && dt > 0) {
    const Eigen::Vector2d prev(last_desired_[i].pan_rad, last_desired_[i].tilt_rad);
    const double a = dt / (p_.rate_filter_s + dt);
    rate_[i] += a * ((theta - prev) / dt - rate_[i]);
  } else {
    rate_[i].setZero();
  }
  last_desired_[i] = {pan, tilt, goal.zoom};
  goal.pan_rad = pan + rate_[i].x() * p_.lead_s;
  goal.tilt_rad = tilt + rate_[i].y() * p_.lead_s;
  return goal;
}

void Controller::observe(double t_s, const Observation& o) {
  Eigen::Matrix3d cov = o.covariance_m2;
  if (!cov.allFinite() || !(cov.trace() > 0)) {
    cov = Eigen::Matrix3d::Identity() * p_.kf_position_sigma_m * p_.kf_position_sigma_m;
  }
  if (!kalman_.update(t_s, o.position_head_m, cov)) ++outliers_rejected_;
}

PtzPose Controller::desiredSmith(Side side, const Observation& o, const PtzPose& at_capture,
                                 double t_s, double dt) {
  const int i = static_cast<int>(side);
  SmithPredictor& pan_axis = smith_[2 * i];
  SmithPredictor& tilt_axis = smith_[2 * i + 1];
  // Where the target will be while the command issued now acts (mid-frame after the delay).
  const double t_act = t_s + pan_axis.delayS() + (dt > 0 ? dt : 1.0 / 30) / 2;
  Observation ahead = o;
  ahead.position_head_m = kalman_.positionAt(t_act);
  PtzPose goal = setpoint_[i];
  goal.zoom = zoomFor(side, ahead, at_capture);
  const Eigen::Vector2d centre = imageCentre(rig_.camera(side));
  double pan = 0, tilt = 0;
  if (!aimAt(rig_, side, ahead.position_head_m, goal.zoom, centre, &pan, &tilt)) {
    return setpoint_[i];
  }
  // The reference's rate from the filter's velocity, through the same inverse kinematics.
  constexpr double kRateStepS = 0.1;
  double pan_before = pan, tilt_before = tilt;
  aimAt(rig_, side, kalman_.positionAt(t_act - kRateStepS), goal.zoom, centre, &pan_before,
        &tilt_before);
  goal.pan_rad =
      pan_axis.command(t_s, pan, (pan - pan_before) / kRateStepS, at_capture.pan_rad, t_s);
  goal.tilt_rad =
      tilt_axis.command(t_s, tilt, (tilt - tilt_before) / kRateStepS, at_capture.tilt_rad, t_s);
  return goal;
}

void Controller::smithSent(double t_s, const PtzPose& left_at_capture,
                           const PtzPose& right_at_capture) {
  const std::array<PtzPose, 2> measured = {left_at_capture, right_at_capture};
  for (int i = 0; i < 2; ++i) {
    if (!smith_[2 * i].started()) smith_[2 * i].reset(t_s, measured[i].pan_rad);
    if (!smith_[2 * i + 1].started()) smith_[2 * i + 1].reset(t_s, measured[i].tilt_rad);
    smith_[2 * i].sent(t_s, setpoint_[i].pan_rad);
    smith_[2 * i + 1].sent(t_s, setpoint_[i].tilt_rad);
  }
}

void Controller::slewTowards(const std::array<PtzPose, 2>& goal, double dt, double rate_angle,
                             double rate_zoom) {
  for (int i = 0; i < 2; ++i) {
    PtzPose& s = setpoint_[i];
    s.pan_rad = clampAxis(slew(s.pan_rad, goal[i].pan_rad, rate_angle * dt), p_.limits.axis[0]);
    s.tilt_rad = clampAxis(slew(s.tilt_rad, goal[i].tilt_rad, rate_angle * dt), p_.limits.axis[1]);
    s.zoom = clampAxis(slew(s.zoom, goal[i].zoom, rate_zoom * dt), p_.limits.axis[2]);
  }
}

std::array<PtzPose, 2> Controller::update(double t_s, const std::optional<Observation>& target,
                                          const PtzPose& left_at_capture,
                                          const PtzPose& right_at_capture) {
  if (last_t_s_ && t_s < *last_t_s_) {
    // Time went back (a restarted simulator, realtime to lockstep): start afresh.
    last_t_s_.reset();
    last_seen_t_s_.reset();
    tracking_ = false;
    rate_ = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
    kalman_.reset();
    smith_ = makeSmith(p_);
  }
  if (!last_t_s_) {
    setpoint_ = {left_at_capture, right_at_capture};  // start where the heads are
  }
  const double dt = last_t_s_ ? std::clamp(t_s - *last_t_s_, 0.0, 1.0) : 0.0;
  last_t_s_ = t_s;
  const bool smith = p_.mode == "smith";
  if (target && plausible(*target)) {
    std::array<PtzPose, 2> goal;
    if (smith) {
      observe(t_s, *target);
      goal = {desiredSmith(Side::kLeft, *target, left_at_capture, t_s, dt),
              desiredSmith(Side::kRight, *target, right_at_capture, t_s, dt)};
    } else {
      goal = {desired(Side::kLeft, *target, left_at_capture, dt),
              desired(Side::kRight, *target, right_at_capture, dt)};
    }
    tracking_ = true;
    last_seen_t_s_ = t_s;
    // The first setpoint after start or a loss slews too; dt = 0 means "this frame": allow one
    // frame's worth at 30 Hz.
    const double step_dt = dt > 0 ? dt : 1.0 / 30;
    slewTowards(goal, step_dt, p_.max_setpoint_rate, p_.max_setpoint_rate);
  } else {
    tracking_ = false;
    rate_ = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
    if (!last_seen_t_s_ || t_s - *last_seen_t_s_ >= p_.lost_hold_s) {
      kalman_.reset();
      slewTowards({PtzPose{0, 0, 1}, PtzPose{0, 0, 1}}, dt, p_.home_rate, p_.home_rate);
    }  // else hold
  }
  if (smith) smithSent(t_s, left_at_capture, right_at_capture);
  return setpoint_;
}

}  // namespace ptz::control
