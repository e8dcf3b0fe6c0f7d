// ptz-control: OBJECT_TRACKS (+ PTZ_STATE) -> PTZ_SETPOINT + CONTROL_STATE, one setpoint per
// tracks message, each carrying the utime and seq of the frame it answers (lockstep and latency
// use them). The target is the track ptz-detect locked on: measured when the frame updated it,
// its prediction while it coasts.
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>

#include "common/freshness.hpp"
#include "common/transport/transport.hpp"
#include "control/controller/controller.hpp"
#include "control/controller/delay_monitor.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"

namespace ptz::control {
namespace {

void declare(Params& p) {
  addTransportParams(p);
  addFreshnessParams(p, "tracks", 500.0, "an OBJECT_TRACKS");
  addPlantParams(p);  // the limits; the motor model itself is the plant's business
  const ControllerParams d;
  declareRigParams(p);
  p.add("mode", "track",
        "track (default: zero steady-state error, feed-forward), paper, or smith (long delays)");
  p.add("paper_gain", d.paper_gain, "", "P gain of the paper mode", Range::above(0));
  p.add("zoom_mode", "size", "size (keep target_radius_vga_px) or hold");
  p.add(
      "target_radius_vga_px", d.target_radius_vga_px, "px",
      "reference apparent radius of the target in VGA-equivalent px (scaled with the image width)",
      Range::above(0));
  p.add("max_zoom", d.max_zoom, "ratio", "highest zoom the controller asks for", Range::above(0));
  p.add("lead_s", d.lead_s, "s",
        "track: feed-forward horizon, the motor's time constant T plus the capture -> command "
        "delay (lockstep: ~0 + half a frame; on a real rig: T + delay_us_p50 of the status)",
        Range::atLeast(0));
  p.add("rate_filter_s", d.rate_filter_s, "s", "time constant of the angular rate estimate",
        Range::above(0));
  p.add("max_setpoint_rate", d.max_setpoint_rate, "rad/s", "setpoint slew limit (zoom: ratio/s)",
        Range::above(0));
  p.add("lost_hold_s", d.lost_hold_s, "s",
        "hold the last setpoint this long without a target before searching (or going home)",
        Range::atLeast(0));
  p.add("lost_mode", d.lost_mode.c_str(), "search (scan the search region) or home (return home)");
  p.add("coast_s", d.coast_s, "s",
        "follow a hidden target's predicted path this long before searching", Range::atLeast(0));
  p.add("limit_wait_s", d.limit_wait_s, "s",
        "wait this long at an axis limit for a target lost beyond it", Range::atLeast(0));
  const SearchParams sd;
  p.add("search_pan_min_rad", sd.pan_min_rad, "rad", "search region: lowest pan (within pan_min)",
        Range::between(-6.3, 6.3));
  p.add("search_pan_max_rad", sd.pan_max_rad, "rad", "search region: highest pan (within pan_max)",
        Range::between(-6.3, 6.3));
  p.addOrder("search_pan_min_rad", "search_pan_max_rad");
  p.add("search_tilt_min_rad", sd.tilt_min_rad, "rad",
        "search region: lowest tilt (within tilt_min)", Range::between(-6.3, 6.3));
  p.add("search_tilt_max_rad", sd.tilt_max_rad, "rad",
        "search region: highest tilt (within tilt_max)", Range::between(-6.3, 6.3));
  p.addOrder("search_tilt_min_rad", "search_tilt_max_rad");
  p.add("search_overlap", sd.overlap, "", "search: share of the field of view rows overlap by",
        Range::between(0, 0.9));
  p.add("search_range_m", sd.range_m, "m", "search: distance the cameras converge at",
        Range::above(0));
  p.add("search_dwell_s", sd.dwell_s, "s", "search: time spent looking at the last seen direction",
        Range::atLeast(0));
  p.add("search_rate_rad_s", sd.rate_rad_s, "rad/s",
        "search: sweep speed (at most max_setpoint_rate)", Range::above(0));
  p.add("home_rate", d.home_rate, "rad/s", "speed of the return home after that (zoom: ratio/s)",
        Range::above(0));
  p.add("min_range_m", d.min_range_m, "m", "nearer targets are implausible and ignored",
        Range::above(0));
  p.add("max_range_m", d.max_range_m, "m", "farther targets are implausible and ignored",
        Range::above(0));
  p.addOrder("min_range_m", "max_range_m");
  p.add("smith_filter_s", d.smith_filter_s, "s",
        "smith: time constant of the filter on the model error seen at capture", Range::atLeast(0));
  p.add("smith_extra_delay_s", d.smith_extra_delay_s, "s",
        "smith: delay from capture to the command (delay_us_p50 of the status) added to "
        "dead_time_s",
        Range::atLeast(0));
  p.add("kf_model", d.kf_model.c_str(),
        "smith: the target filter, ct (coordinated turn: predicts along curves) or cv (constant "
        "velocity)");
  p.add("kf_accel_psd_m2_s3", d.kalman.accel_psd_m2_s3, "m^2/s^3",
        "smith: spectral density of the target's acceleration (Kalman process noise; ct: of its "
        "changes of speed and turn beyond the model)",
        Range::above(0));
  p.add("kf_turn_psd_rad2_s3", d.turn_kalman.turn_psd_rad2_s3, "rad^2/s^3",
        "smith, ct: spectral density of the change of the target's turn rate", Range::above(0));
  p.add("kf_position_sigma_m", d.kf_position_sigma_m, "m",
        "smith: position noise of a pose that carries no covariance", Range::above(0));
  p.add("kf_gate_chi2", d.kalman.gate_chi2, "",
        "smith: poses farther from the prediction (Mahalanobis^2) are outliers", Range::above(0));
  p.add("min_phase_margin_deg", 30.0, "deg",
        "warn when the measured delay leaves the paper's loop less phase margin",
        Range::between(0, 180));
}

ControllerParams controllerParams(const Params& p) {
  ControllerParams c;
  c.mode = p.getString("mode");
  c.paper_gain = p.getDouble("paper_gain");
  c.zoom_mode = p.getString("zoom_mode");
  c.target_radius_vga_px = p.getDouble("target_radius_vga_px");
  c.max_zoom = p.getDouble("max_zoom");
  c.lead_s = p.getDouble("lead_s");
  c.rate_filter_s = p.getDouble("rate_filter_s");
  c.max_setpoint_rate = p.getDouble("max_setpoint_rate");
  c.lost_hold_s = p.getDouble("lost_hold_s");
  c.lost_mode = p.getString("lost_mode");
  c.coast_s = p.getDouble("coast_s");
  c.limit_wait_s = p.getDouble("limit_wait_s");
  c.home_rate = p.getDouble("home_rate");
  c.min_range_m = p.getDouble("min_range_m");
  c.max_range_m = p.getDouble("max_range_m");
  c.limits = plantParamsFrom(p);
  // The search region within the axis limits.
  const AxisParams& pan = c.limits.axis[0];
  const AxisParams& tilt = c.limits.axis[1];
  c.search.pan_min_rad = std::max(p.getDouble("search_pan_min_rad"), pan.min_position);
  c.search.pan_max_rad = std::min(p.getDouble("search_pan_max_rad"), pan.max_position);
  c.search.tilt_min_rad = std::max(p.getDouble("search_tilt_min_rad"), tilt.min_position);
  c.search.tilt_max_rad = std::min(p.getDouble("search_tilt_max_rad"), tilt.max_position);
  if (c.search.pan_min_rad > c.search.pan_max_rad ||
      c.search.tilt_min_rad > c.search.tilt_max_rad) {
    throw p.invalid("search_pan_min_rad", "the search region lies outside the axis limits");
  }
  c.search.overlap = p.getDouble("search_overlap");
  c.search.range_m = p.getDouble("search_range_m");
  c.search.dwell_s = p.getDouble("search_dwell_s");
  c.search.rate_rad_s = p.getDouble("search_rate_rad_s");
  c.smith_filter_s = p.getDouble("smith_filter_s");
  c.smith_extra_delay_s = p.getDouble("smith_extra_delay_s");
  c.kf_model = p.getString("kf_model");
  c.kalman.accel_psd_m2_s3 = p.getDouble("kf_accel_psd_m2_s3");
  c.turn_kalman.accel_psd_m2_s3 = c.kalman.accel_psd_m2_s3;
  c.turn_kalman.turn_psd_rad2_s3 = p.getDouble("kf_turn_psd_rad2_s3");
  c.kf_position_sigma_m = p.getDouble("kf_position_sigma_m");
  c.kalman.gate_chi2 = p.getDouble("kf_gate_chi2");
  c.turn_kalman.gate_chi2 = c.kalman.gate_chi2;
  // The numbers' ranges are their declarations'.
  if (c.mode != "track" && c.mode != "paper" && c.mode != "smith") {
    throw p.invalid("mode", "must be track, paper or smith");
  }
  if (c.kf_model != "ct" && c.kf_model != "cv") throw p.invalid("kf_model", "must be ct or cv");
  if (c.zoom_mode != "size" && c.zoom_mode != "hold") {
    throw p.invalid("zoom_mode", "must be size or hold");
  }
  if (c.lost_mode != "search" && c.lost_mode != "home") {
    throw p.invalid("lost_mode", "must be search or home");
  }
  return c;
}

std::string millis(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", v);
  return text;
}

bool finitePose(const ptzstereo::ptz_head_setpoint_t& h) {
  return std::isfinite(h.pan_rad) && std::isfinite(h.tilt_rad) && std::isfinite(h.zoom);
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

// The target track of a tracks message as an observation (none when there is no target, or it
// is tentative). *problem: why a target named by target_id cannot be used ("" when it can).
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

class ControlNode {
 public:
  ControlNode(const Params& p, lcm::LCM* lcm, StereoRig rig)
      : lcm_(lcm),
        status_(lcm, p, "ptz-control"),
        controller_(std::move(rig), controllerParams(p)),
        // The paper's loop model of the pan axis: P gain times motor gain, the motor's T.
        delay_monitor_({p.getDouble("paper_gain") * p.getDouble("pan_gain"),
                        p.getDouble("pan_time_constant_s"), 0.0},
                       p.getDouble("dead_time_s"), p.getDouble("min_phase_margin_deg")),
        // Smith mode: the delay its model assumes, checked against the measured one.
        smith_delay_s_(p.getString("mode") == "smith"
                           ? p.getDouble("dead_time_s") + p.getDouble("smith_extra_delay_s")
                           : -1),
        tracks_freshness_(freshnessFrom(p, "tracks")),
        ch_tracks_(channel(p, channels::kObjectTracks)),
        ch_state_(channel(p, channels::kPtzState)),
        ch_setpoint_(channel(p, channels::kPtzSetpoint)),
        ch_control_state_(channel(p, channels::kControlState)) {
    tracks_ = std::make_unique<SafeSubscription<ptzstereo::object_tracks_t>>(
        *lcm_, ch_tracks_, status_,
        [this](const std::string& ch, const ptzstereo::object_tracks_t& m) { onTracks(ch, &m); },
        Delivery::kNewest);
    states_ = std::make_unique<SafeSubscription<ptzstereo::ptz_state_t>>(
        *lcm_, ch_state_, status_,
        [this](const std::string& ch, const ptzstereo::ptz_state_t&) { status_.countIn(ch, -1); },
        Delivery::kNewest);
    status_.expectInput(ch_tracks_);
  }

  int run() { return serveUntilStopped(*lcm_, status_); }

 private:
  void onTracks(const std::string& ch, const ptzstereo::object_tracks_t* m) {
    const int64_t received = wallUtime();
    const bool wall_clock = captureOnWallClock(m->utime, m->publish_utime);
    const Freshness fresh =
        judgeFreshness(m->utime, m->publish_utime, received, tracks_freshness_, wall_clock);
    if (fresh != Freshness::kFresh) {
      status_.countDropped(ch, freshnessReason(fresh));
      log_.warn("fresh", std::string("ptz-control: dropped a ") + freshnessReason(fresh) +
                             " tracks message (frame " + std::to_string(m->frame_seq) + ")");
      return;
    }
    if (!finitePose(m->left_ptz) || !finitePose(m->right_ptz)) {
      status_.countDropped(ch, "nonfinite_ptz");
      log_.warn("ptz", "ptz-control: tracks message with a non-finite camera pose: dropped");
      return;
    }
    status_.countIn(ch, latencyMs(m->utime, received));
    const PtzPose lc{m->left_ptz.pan_rad, m->left_ptz.tilt_rad, m->left_ptz.zoom};
    const PtzPose rc{m->right_ptz.pan_rad, m->right_ptz.tilt_rad, m->right_ptz.zoom};
    std::string problem;
    std::optional<Observation> target = targetOf(*m, &problem);
    if (!problem.empty()) {
      status_.increment(problem);
      log_.warn(problem, "ptz-control: target_id " + std::to_string(m->target_id) + ": " +
                             (problem == "target_bad_state" ? "a track state none of 0, 1, 2"
                                                            : "none of the message's tracks") +
                             ": no target");
    }
    if (target && !controller_.plausible(*target, lc, rc)) {
      status_.increment("implausible_poses");
      log_.warn("implausible", "ptz-control: implausible target ignored");
      target.reset();
    }
    const auto sp = controller_.update(m->utime * 1e-6, target, lc, rc);
    ptzstereo::ptz_setpoint_t out{};
    out.utime = m->utime;
    out.frame_seq = m->frame_seq;
    out.left = {sp[0].pan_rad, sp[0].tilt_rad, sp[0].zoom};
    out.right = {sp[1].pan_rad, sp[1].tilt_rad, sp[1].zoom};
    out.publish_utime = wallUtime();
    status_.publish(ch_setpoint_, out, latencyMs(m->utime, out.publish_utime));
    publishState(*m, target ? m->target_id : -1);
    status_.increment(controller_.tracking() ? "setpoints_tracking" : "setpoints_without_target");
    status_.increment(std::string("setpoints_") + controlStateName(controller_.state()));
    status_.setCounter("kalman_outliers", controller_.outliersRejected());
    // Lockstep: capture times are sim time; the delay is measured on the wall clock only.
    if (wall_clock) monitorDelay(saturatingDiffUs(out.publish_utime, m->utime) * 1e-6);
  }

  void publishState(const ptzstereo::object_tracks_t& m, int64_t target_id) {
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
    if (s.reason != last_reason_) {
      std::fprintf(stderr, "ptz-control: %s\n", s.reason.c_str());
      last_reason_ = s.reason;
    }
    s.publish_utime = wallUtime();
    status_.publish(ch_control_state_, s, latencyMs(m.utime, s.publish_utime));
  }

  // Every 30 setpoints: the delay distribution and the phase margin it leaves, in the status.
  void monitorDelay(double delay_s) {
    delay_monitor_.add(delay_s);
    if (delay_monitor_.samples() < 30) return;
    const DelayMonitor::Report r = delay_monitor_.report();
    status_.setCounter("delay_us_p50", std::llround(r.delay_ms_p50 * 1000));
    status_.setCounter("delay_us_p99", std::llround(r.delay_ms_p99 * 1000));
    status_.setCounter("phase_margin_millideg", std::llround(r.phase_margin_deg * 1000));
    std::string warning;
    if (smith_delay_s_ >= 0) {
      // The paper loop's margin means nothing to the Smith predictor; a wrong model delay does.
      const double error_s = r.delay_ms_p50 / 1000 - smith_delay_s_;
      status_.setCounter("smith_delay_error_us", std::llround(error_s * 1e6));
      if (std::abs(error_s) > std::max(0.1 * smith_delay_s_, 0.01)) {
        warning = "measured delay p50 " + millis(r.delay_ms_p50) + " ms, the smith model assumes " +
                  millis(smith_delay_s_ * 1000) + " ms: set smith_extra_delay_s";
      }
    } else if (r.below_threshold) {
      warning = "delay p99 " + millis(r.delay_ms_p99) + " ms leaves a phase margin of " +
                millis(r.phase_margin_deg) + " deg";
    }
    if (!warning.empty()) {
      status_.setState(ptzstereo::process_status_t::STATE_WARN, warning);
      log_.warn("margin", "ptz-control: " + warning);
    } else {
      status_.setState(ptzstereo::process_status_t::STATE_OK, "");
    }
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  RateLimitedLog log_;
  Controller controller_;
  DelayMonitor delay_monitor_;
  double smith_delay_s_;  // < 0: not in smith mode
  FreshnessLimits tracks_freshness_;
  std::string ch_tracks_, ch_state_, ch_setpoint_, ch_control_state_;
  std::string last_reason_;
  std::unique_ptr<SafeSubscription<ptzstereo::object_tracks_t>> tracks_;
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_state_t>> states_;
};

}  // namespace
}  // namespace ptz::control

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-control",
                "Steers pan, tilt and zoom of both heads to keep the target track of "
                "OBJECT_TRACKS centred in both images at a constant apparent size; "
                "publishes PTZ_SETPOINT and CONTROL_STATE, one per OBJECT_TRACKS.");
  control::declare(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    control::ControlNode node(p, &lcm, rigFromParams(p));
    return node.run();
  });
}
