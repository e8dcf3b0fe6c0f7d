#include "control/controller/controller.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

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

const char* controlStateName(ControlState s) {
  switch (s) {
    case ControlState::kTracking:
      return "tracking";
    case ControlState::kCoasting:
      return "coasting";
    case ControlState::kSearching:
      return "searching";
    case ControlState::kHolding:
      return "holding";
    case ControlState::kHoming:
      return "homing";
  }
  return "?";
}

Controller::Controller(StereoRig rig, ControllerParams params)
    : rig_(std::move(rig)),
      p_(std::move(params)),
      search_(rig_, p_.search),
      kalman_(p_.kalman),
      turn_kalman_(p_.turn_kalman),
      smith_(makeSmith(p_)) {}

void Controller::setState(ControlState s, std::string reason) {
  state_ = s;
  reason_ = std::move(reason);
}

bool Controller::plausible(const Observation& o, const PtzPose& left_at_capture,
                           const PtzPose& right_at_capture) const {
  if (!o.position_head_m.allFinite() || !std::isfinite(o.radius_m)) return false;
  // In front of both cameras as they pointed at capture, and within range of each: anywhere the
  // heads can point, not only in front of the head frame.
  for (const Side side : {Side::kLeft, Side::kRight}) {
    const PtzPose& at = side == Side::kLeft ? left_at_capture : right_at_capture;
    Eigen::Matrix3d R;
    Eigen::Vector3d c;
    rig_.cameraPose(side, at.pan_rad, at.tilt_rad, &R, &c);
    const Eigen::Vector3d p_camera = R.transpose() * (o.position_head_m - c);
    const double range = p_camera.norm();
    if (!(p_camera.z() > 0) || range < p_.min_range_m || range > p_.max_range_m) return false;
  }
  return true;
}

double Controller::zoomFor(Side side, const Observation& o, const PtzPose& at_capture) const {
  const double current = setpoint_[static_cast<int>(side)].zoom;
  if (p_.zoom_mode != "size" || o.radius_m <= 0) return current;
  Eigen::Matrix3d R;
  Eigen::Vector3d c;
  rig_.cameraPose(side, at_capture.pan_rad, at_capture.tilt_rad, &R, &c);
  const double range = (o.position_head_m - c).norm();
  const double radius_px = p_.target_radius_vga_px * rig_.camera(side).width / kVgaWidthPx;
  const double fx = radius_px * range / o.radius_m;
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
  if (o.velocity_m_s) {
    // Track, from a track: the rate of theta* from the track's velocity (no filter lag), so
    // u = theta* + lead_s * d(theta*)/dt inverts the axis's PT1 on curves as on straight lines.
    constexpr double kStepS = 0.02;
    const Eigen::Vector3d& v = *o.velocity_m_s;
    double pan_a = pan, tilt_a = tilt, pan_b = pan, tilt_b = tilt;
    const bool rate_ok = aimAt(rig_, side, o.position_head_m + v * kStepS, goal.zoom,
                               imageCentre(spec), &pan_a, &tilt_a) &&
                         aimAt(rig_, side, o.position_head_m - v * kStepS, goal.zoom,
                               imageCentre(spec), &pan_b, &tilt_b);
    rate_[i] =
        rate_ok ? Eigen::Vector2d((pan_a - pan_b) / (2 * kStepS), (tilt_a - tilt_b) / (2 * kStepS))
                : Eigen::Vector2d(0, 0);
    last_desired_[i] = {pan, tilt, goal.zoom};
    goal.pan_rad = pan + rate_[i].x() * p_.lead_s;
    goal.tilt_rad = tilt + rate_[i].y() * p_.lead_s;
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
  if (!usableCovariance(cov)) {  // unknown (zero), or not a covariance at all
    cov = Eigen::Matrix3d::Identity() * p_.kf_position_sigma_m * p_.kf_position_sigma_m;
  }
  const bool accepted = p_.kf_model == "ct" ? turn_kalman_.update(t_s, o.position_head_m, cov)
                                            : kalman_.update(t_s, o.position_head_m, cov);
  if (!accepted) ++outliers_rejected_;
}

bool Controller::targetFilterStarted() const {
  return p_.kf_model == "ct" ? turn_kalman_.initialised() : kalman_.initialised();
}

Eigen::Vector3d Controller::predictedAt(double t_s) const {
  return p_.kf_model == "ct" ? turn_kalman_.positionAt(t_s) : kalman_.positionAt(t_s);
}

void Controller::resetTargetFilter() {
  kalman_.reset();
  turn_kalman_.reset();
}

void Controller::follows(int64_t track_id) {
  if (followed_id_ && *followed_id_ != track_id) {
    resetTargetFilter();
    tracking_ = false;  // the track mode's rate estimate restarts from the new target
    rate_ = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  }
  followed_id_ = track_id;
}

PtzPose Controller::desiredSmith(Side side, const Observation& o, const PtzPose& at_capture,
                                 double t_s, double dt) {
  const int i = static_cast<int>(side);
  SmithPredictor& pan_axis = smith_[2 * i];
  SmithPredictor& tilt_axis = smith_[2 * i + 1];
  // Where the target will be while the command issued now acts (mid-frame after the delay).
  const double t_act = t_s + pan_axis.delayS() + (dt > 0 ? dt : 1.0 / 30) / 2;
  Observation ahead = o;
  ahead.position_head_m = predictedAt(t_act);
  PtzPose goal = setpoint_[i];
  goal.zoom = zoomFor(side, ahead, at_capture);
  const Eigen::Vector2d centre = imageCentre(rig_.camera(side));
  double pan = 0, tilt = 0;
  if (!aimAt(rig_, side, ahead.position_head_m, goal.zoom, centre, &pan, &tilt)) {
    return setpoint_[i];
  }
  // The reference's rate at t_act through the same inverse kinematics: a central difference
  // (a one-sided one lags by half its step, which a turning prediction would show).
  constexpr double kRateStepS = 0.05;
  double pan_a = pan, tilt_a = tilt, pan_b = pan, tilt_b = tilt;
  const bool rate_ok =
      aimAt(rig_, side, predictedAt(t_act + kRateStepS), goal.zoom, centre, &pan_a, &tilt_a) &&
      aimAt(rig_, side, predictedAt(t_act - kRateStepS), goal.zoom, centre, &pan_b, &tilt_b);
  const double pan_rate = rate_ok ? (pan_a - pan_b) / (2 * kRateStepS) : 0;
  const double tilt_rate = rate_ok ? (tilt_a - tilt_b) / (2 * kRateStepS) : 0;
  goal.pan_rad = pan_axis.command(t_s, pan, pan_rate, at_capture.pan_rad, t_s);
  goal.tilt_rad = tilt_axis.command(t_s, tilt, tilt_rate, at_capture.tilt_rad, t_s);
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

bool Controller::beyondLimits(const std::array<PtzPose, 2>& goal) const {
  const double m = p_.limit_margin_rad;
  for (const PtzPose& g : goal) {
    if (g.pan_rad < p_.limits.axis[0].min_position + m ||
        g.pan_rad > p_.limits.axis[0].max_position - m ||
        g.tilt_rad < p_.limits.axis[1].min_position + m ||
        g.tilt_rad > p_.limits.axis[1].max_position - m) {
      return true;
    }
  }
  return false;
}

std::array<PtzPose, 2> Controller::follow(double t_s, const Observation& o,
                                          const PtzPose& left_at_capture,
                                          const PtzPose& right_at_capture, double dt) {
  if (p_.mode == "smith") {
    // A coasting track's prediction starts a filter that has nothing (a new target that is
    // hidden): never predict from another target's state.
    if (o.measured || !targetFilterStarted()) observe(t_s, o);
    return {desiredSmith(Side::kLeft, o, left_at_capture, t_s, dt),
            desiredSmith(Side::kRight, o, right_at_capture, t_s, dt)};
  }
  return {desired(Side::kLeft, o, left_at_capture, dt),
          desired(Side::kRight, o, right_at_capture, dt)};
}

void Controller::lost(double t_s, double dt, const PtzPose& left_at_capture) {
  tracking_ = false;
  rate_ = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  const double since = t_s - (last_seen_t_s_ ? *last_seen_t_s_ : *first_t_s_);
  if (since < p_.lost_hold_s) {
    setState(ControlState::kHolding, last_seen_t_s_ ? "target lost: holding" : "no target yet");
    return;
  }
  if (p_.lost_mode == "home") {
    resetTargetFilter();
    setState(ControlState::kHoming, "no target: returning home");
    slewTowards({PtzPose{0, 0, 1}, PtzPose{0, 0, 1}}, dt, p_.home_rate, p_.home_rate);
    return;
  }
  if (lost_at_limit_ && since < p_.limit_wait_s) {
    setState(ControlState::kHolding, "target lost beyond an axis limit: waiting there");
    return;
  }
  resetTargetFilter();
  const Eigen::Vector2d from(setpoint_[0].pan_rad, setpoint_[0].tilt_rad);
  if (!search_.active()) search_.start(from, last_seen_direction_);
  const SearchView view = search_.view(t_s, setpoint_[0], left_at_capture);
  std::array<PtzPose, 2> goal = setpoint_;
  for (int i = 0; i < 2; ++i) {
    const Side side = i == 0 ? Side::kLeft : Side::kRight;
    search_.aim(side, view, &goal[i].pan_rad, &goal[i].tilt_rad);
    goal[i].zoom = view.zoom;
  }
  std::ostringstream reason;
  reason << "no target: searching, waypoint " << search_.waypoint() + 1 << " of "
         << search_.waypoints() << " at zoom " << std::setprecision(3) << view.zoom;
  setState(ControlState::kSearching, reason.str());
  slewTowards(goal, dt, std::min(p_.search.rate_rad_s, p_.max_setpoint_rate), p_.max_setpoint_rate);
}

std::array<PtzPose, 2> Controller::update(double t_s, const std::optional<Observation>& target,
                                          const PtzPose& left_at_capture,
                                          const PtzPose& right_at_capture) {
  if (last_t_s_ && t_s < *last_t_s_) {
    // Time went back (a restarted simulator, realtime to lockstep): start afresh.
    last_t_s_.reset();
    last_seen_t_s_.reset();
    first_t_s_.reset();
    last_seen_direction_.reset();
    lost_at_limit_ = false;
    tracking_ = false;
    rate_ = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
    resetTargetFilter();
    followed_id_.reset();
    smith_ = makeSmith(p_);
    search_.stop();
  }
  if (!last_t_s_) {
    setpoint_ = {left_at_capture, right_at_capture};  // start where the heads are
    first_t_s_ = t_s;
  }
  const double dt = last_t_s_ ? std::clamp(t_s - *last_t_s_, 0.0, 1.0) : 0.0;
  last_t_s_ = t_s;
  const bool usable = target && plausible(*target, left_at_capture, right_at_capture);
  const bool coasting = usable && !target->measured;
  const double since_seen = last_seen_t_s_ ? t_s - *last_seen_t_s_ : INFINITY;
  if (usable && (!coasting || since_seen <= p_.coast_s)) {
    follows(target->track_id);
    const std::array<PtzPose, 2> goal = follow(t_s, *target, left_at_capture, right_at_capture, dt);
    const bool at_limit = beyondLimits(goal);
    if (coasting) {
      setState(at_limit ? ControlState::kHolding : ControlState::kCoasting,
               at_limit ? "target hidden beyond an axis limit: waiting there"
                        : "target hidden: following its prediction");
    } else {
      setState(ControlState::kTracking, "tracking");
      tracking_ = true;
      last_seen_t_s_ = t_s;
    }
    lost_at_limit_ = at_limit;
    search_.stop();
    // The first setpoint after start or a loss slews too; dt = 0 means "this frame": allow one
    // frame's worth at 30 Hz.
    const double step_dt = dt > 0 ? dt : 1.0 / 30;
    slewTowards(goal, step_dt, p_.max_setpoint_rate, p_.max_setpoint_rate);
    if (!coasting)
      last_seen_direction_ = Eigen::Vector2d(setpoint_[0].pan_rad, setpoint_[0].tilt_rad);
  } else {
    lost(t_s, dt, left_at_capture);
  }
  since_target_s_ = t_s - (last_seen_t_s_ ? *last_seen_t_s_ : *first_t_s_);
  if (p_.mode == "smith") smithSent(t_s, left_at_capture, right_at_capture);
  return setpoint_;
}

}  // namespace ptz::control
