// ptz-control: OBJECT_POSE (+ PTZ_STATE) -> PTZ_SETPOINT, one setpoint per pose message, each
// carrying the utime and seq of the frame it answers (lockstep and latency use them).
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>

#include "common/freshness.hpp"
#include "common/transport.hpp"
#include "control/controller/controller.hpp"
#include "control/controller/delay_monitor.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"

namespace ptz::control {
namespace {

void declare(Params& p) {
  addTransportParams(p);
  addFreshnessParams(p, "pose", 500.0, "an OBJECT_POSE");
  addPlantParams(p);  // the limits; the motor model itself is the plant's business
  const ControllerParams d;
  p.add("rig_file", "", "rig file (OpenCV YAML); empty: the built-in default rig");
  p.add("mode", "track",
        "track (default: zero steady-state error, feed-forward), paper, or smith (long delays)");
  p.add("paper_gain", d.paper_gain, "", "P gain of the paper mode", Range::above(0));
  p.add("zoom_mode", "size", "size (keep target_radius_px) or hold");
  p.add("target_radius_px", d.target_radius_px, "px", "reference apparent radius of the target",
        Range::above(0));
  p.add("max_zoom", d.max_zoom, "ratio", "highest zoom the controller asks for", Range::above(0));
  p.add("lead_s", d.lead_s, "s", "feed-forward horizon of the track mode", Range::atLeast(0));
  p.add("rate_filter_s", d.rate_filter_s, "s", "time constant of the angular rate estimate",
        Range::above(0));
  p.add("max_setpoint_rate", d.max_setpoint_rate, "rad/s", "setpoint slew limit (zoom: ratio/s)",
        Range::above(0));
  p.add("lost_hold_s", d.lost_hold_s, "s", "hold the last setpoint this long without a target",
        Range::atLeast(0));
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
  p.add("kf_accel_psd_m2_s3", d.kalman.accel_psd_m2_s3, "m^2/s^3",
        "smith: spectral density of the target's acceleration (Kalman process noise)",
        Range::above(0));
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
  c.target_radius_px = p.getDouble("target_radius_px");
  c.max_zoom = p.getDouble("max_zoom");
  c.lead_s = p.getDouble("lead_s");
  c.rate_filter_s = p.getDouble("rate_filter_s");
  c.max_setpoint_rate = p.getDouble("max_setpoint_rate");
  c.lost_hold_s = p.getDouble("lost_hold_s");
  c.home_rate = p.getDouble("home_rate");
  c.min_range_m = p.getDouble("min_range_m");
  c.max_range_m = p.getDouble("max_range_m");
  c.limits = plantParamsFrom(p);
  c.smith_filter_s = p.getDouble("smith_filter_s");
  c.smith_extra_delay_s = p.getDouble("smith_extra_delay_s");
  c.kalman.accel_psd_m2_s3 = p.getDouble("kf_accel_psd_m2_s3");
  c.kf_position_sigma_m = p.getDouble("kf_position_sigma_m");
  c.kalman.gate_chi2 = p.getDouble("kf_gate_chi2");
  // The numbers' ranges are their declarations'.
  if (c.mode != "track" && c.mode != "paper" && c.mode != "smith") {
    throw p.invalid("mode", "must be track, paper or smith");
  }
  if (c.zoom_mode != "size" && c.zoom_mode != "hold") {
    throw p.invalid("zoom_mode", "must be size or hold");
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
        pose_freshness_(freshnessFrom(p, "pose")),
        ch_pose_(channel(p, channels::kObjectPose)),
        ch_state_(channel(p, channels::kPtzState)),
        ch_setpoint_(channel(p, channels::kPtzSetpoint)) {
    poses_ = std::make_unique<SafeSubscription<ptzstereo::object_pose_t>>(
        *lcm_, ch_pose_, status_,
        [this](const std::string& ch, const ptzstereo::object_pose_t& m) { onPose(ch, &m); },
        Delivery::kNewest);
    states_ = std::make_unique<SafeSubscription<ptzstereo::ptz_state_t>>(
        *lcm_, ch_state_, status_,
        [this](const std::string& ch, const ptzstereo::ptz_state_t&) { status_.countIn(ch, -1); },
        Delivery::kNewest);
    status_.expectInput(ch_pose_);
  }

  int run() { return serveUntilStopped(*lcm_, status_); }

 private:
  void onPose(const std::string& ch, const ptzstereo::object_pose_t* m) {
    const int64_t received = wallUtime();
    const bool wall_clock = captureOnWallClock(m->utime, m->publish_utime);
    const Freshness fresh =
        judgeFreshness(m->utime, m->publish_utime, received, pose_freshness_, wall_clock);
    if (fresh != Freshness::kFresh) {
      status_.countDropped(ch, freshnessReason(fresh));
      log_.warn("fresh", std::string("ptz-control: dropped a ") + freshnessReason(fresh) +
                             " pose (frame " + std::to_string(m->frame_seq) + ")");
      return;
    }
    if (!finitePose(m->left_ptz) || !finitePose(m->right_ptz)) {
      status_.countDropped(ch, "nonfinite_ptz");
      log_.warn("ptz", "ptz-control: pose message with a non-finite camera pose: dropped");
      return;
    }
    status_.countIn(ch, latencyMs(m->utime, received));
    std::optional<Observation> target;
    if (m->target_index >= 0 && m->target_index < m->num_objects &&
        m->target_index < static_cast<int32_t>(m->objects.size())) {
      const auto& o = m->objects[static_cast<size_t>(m->target_index)];
      Observation obs{
          {o.position_m[0], o.position_m[1], o.position_m[2]},
          o.radius_m,
          Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(o.covariance_m2)};
      if (controller_.plausible(obs)) {
        target = obs;
      } else {
        status_.increment("implausible_poses");
        log_.warn("implausible", "ptz-control: implausible target pose ignored");
      }
    }
    const PtzPose lc{m->left_ptz.pan_rad, m->left_ptz.tilt_rad, m->left_ptz.zoom};
    const PtzPose rc{m->right_ptz.pan_rad, m->right_ptz.tilt_rad, m->right_ptz.zoom};
    const auto sp = controller_.update(m->utime * 1e-6, target, lc, rc);
    ptzstereo::ptz_setpoint_t out{};
    out.utime = m->utime;
    out.frame_seq = m->frame_seq;
    out.left = {sp[0].pan_rad, sp[0].tilt_rad, sp[0].zoom};
    out.right = {sp[1].pan_rad, sp[1].tilt_rad, sp[1].zoom};
    out.publish_utime = wallUtime();
    status_.publish(ch_setpoint_, out, latencyMs(m->utime, out.publish_utime));
    status_.increment(controller_.tracking() ? "setpoints_tracking" : "setpoints_without_target");
    status_.setCounter("kalman_outliers", controller_.outliersRejected());
    // Lockstep: capture times are sim time; the delay is measured on the wall clock only.
    if (wall_clock) monitorDelay(saturatingDiffUs(out.publish_utime, m->utime) * 1e-6);
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
  FreshnessLimits pose_freshness_;
  std::string ch_pose_, ch_state_, ch_setpoint_;
  std::unique_ptr<SafeSubscription<ptzstereo::object_pose_t>> poses_;
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_state_t>> states_;
};

}  // namespace
}  // namespace ptz::control

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-control",
                "Steers pan, tilt and zoom of both heads to keep the target of "
                "OBJECT_POSE centred in both images at a constant apparent size; "
                "publishes PTZ_SETPOINT, one per pose.");
  control::declare(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    control::ControlNode node(p, &lcm, rigFromParams(p));
    return node.run();
  });
}
