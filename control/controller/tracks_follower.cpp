#include "control/controller/tracks_follower.hpp"

#include <cmath>
#include <utility>

namespace ptz::control {
namespace {

bool finitePose(const ptzstereo::ptz_head_setpoint_t& h) {
  return std::isfinite(h.pan_rad) && std::isfinite(h.tilt_rad) && std::isfinite(h.zoom);
}

PtzPose poseOf(const ptzstereo::ptz_head_setpoint_t& h) {
  return {h.pan_rad, h.tilt_rad, h.zoom};
}

ptzstereo::ptz_head_setpoint_t headSetpoint(const PtzPose& p) {
  return {p.pan_rad, p.tilt_rad, p.zoom};
}

int8_t toMessage(ControlState s) {
  switch (s) {
    case ControlState::kTracking:
      return ptzstereo::control_state_t::STATE_TRACKING;
    case ControlState::kCoasting:
      return ptzstereo::control_state_t::STATE_COASTING;
    case ControlState::kSearching:
      return ptzstereo::control_state_t::STATE_SEARCHING;
    case ControlState::kHolding:
      return ptzstereo::control_state_t::STATE_HOLDING;
    case ControlState::kHoming:
      return ptzstereo::control_state_t::STATE_HOMING;
  }
  return ptzstereo::control_state_t::STATE_HOLDING;
}

}  // namespace

std::optional<Observation> targetOf(const ptzstereo::object_tracks_t& m, std::string* problem) {
  problem->clear();
  if (m.target_id < 0) return std::nullopt;
  for (const auto& t : m.tracks) {
    if (t.id != m.target_id) continue;
    if (t.state == ptzstereo::object_track_t::STATE_TENTATIVE) return std::nullopt;
    if (t.state != ptzstereo::object_track_t::STATE_CONFIRMED &&
        t.state != ptzstereo::object_track_t::STATE_COASTING) {
      *problem = "target_bad_state";
      return std::nullopt;
    }
    Observation o;
    o.position_head_m = {t.position_m[0], t.position_m[1], t.position_m[2]};
    o.radius_m = t.radius_m;
    o.covariance_m2 =
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(t.position_covariance_m2);
    const Eigen::Vector3d v(t.velocity_m_s[0], t.velocity_m_s[1], t.velocity_m_s[2]);
    const Eigen::Vector3d a(t.acceleration_m_s2[0], t.acceleration_m_s2[1], t.acceleration_m_s2[2]);
    // A non-finite or absurd velocity or acceleration makes the whole target implausible (the
    // lead would swing the heads to a limit).
    constexpr double kMaxSpeedMS = 50, kMaxAccelerationMS2 = 500;
    o.velocity_m_s = v;
    o.acceleration_m_s2 = a;
    if (!v.allFinite() || !a.allFinite() || v.norm() > kMaxSpeedMS ||
        a.norm() > kMaxAccelerationMS2) {
      o.position_head_m.setConstant(NAN);
    }
    o.measured = t.state == ptzstereo::object_track_t::STATE_CONFIRMED;
    o.track_id = t.id;
    return o;
  }
  *problem = "target_not_in_tracks";
  return std::nullopt;
}

TracksFollower::TracksFollower(StereoRig rig, ControllerParams params)
    : controller_(std::move(rig), std::move(params)) {}

TracksAnswer TracksFollower::follow(const ptzstereo::object_tracks_t& m) {
  TracksAnswer a;
  if (!finitePose(m.left_ptz) || !finitePose(m.right_ptz)) {
    a.dropped =
        CountedEvent{"nonfinite_ptz", "tracks message with a non-finite camera pose: dropped"};
    return a;
  }
  const PtzPose lc = poseOf(m.left_ptz), rc = poseOf(m.right_ptz);
  std::string problem;
  std::optional<Observation> target = targetOf(m, &problem);
  if (!problem.empty()) {
    a.events.push_back(
        {problem, "target_id " + std::to_string(m.target_id) + ": " +
                      (problem == "target_bad_state" ? "a track state none of 0, 1, 2"
                                                     : "none of the message's tracks") +
                      ": no target"});
  }
  if (target && !controller_.plausible(*target, lc, rc)) {
    a.events.push_back({"implausible_poses", "implausible target ignored"});
    target.reset();
  }
  const auto sp = controller_.update(m.utime * 1e-6, target, lc, rc);
  a.setpoint.utime = m.utime;
  a.setpoint.frame_seq = m.frame_seq;
  a.setpoint.left = headSetpoint(sp[0]);
  a.setpoint.right = headSetpoint(sp[1]);
  a.state = stateMessage(m, target ? m.target_id : -1);
  a.reason_changed = a.state.reason != last_reason_;
  last_reason_ = a.state.reason;
  a.events.push_back(
      {controller_.tracking() ? "setpoints_tracking" : "setpoints_without_target", ""});
  a.events.push_back({std::string("setpoints_") + controlStateName(controller_.state()), ""});
  return a;
}

ptzstereo::control_state_t TracksFollower::stateMessage(const ptzstereo::object_tracks_t& m,
                                                        int64_t target_id) const {
  ptzstereo::control_state_t s{};
  s.utime = m.utime;
  s.frame_seq = m.frame_seq;
  s.state = toMessage(controller_.state());
  s.target_id = target_id;
  s.since_target_s = controller_.sinceTargetS();
  const bool searching = controller_.state() == ControlState::kSearching;
  s.search_waypoint = searching ? controller_.search().waypoint() : -1;
  s.search_waypoints = searching ? controller_.search().waypoints() : 0;
  s.reason = controller_.reason();
  return s;
}

}  // namespace ptz::control
