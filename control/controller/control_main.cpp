// ptz-control: OBJECT_TRACKS (+ PTZ_STATE) -> PTZ_SETPOINT + CONTROL_STATE, one setpoint per
// tracks message, each carrying the utime and seq of the frame it answers (lockstep and latency
// use them). The work on a message is TracksFollower's (tracks_follower.hpp); here: flags,
// subscriptions, the freshness of the input, publishing and the status.
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "common/freshness.hpp"
#include "common/transport/intake.hpp"
#include "common/transport/transport.hpp"
#include "control/controller/control_params.hpp"
#include "control/controller/tracks_follower.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"

namespace ptz::control {
namespace {

class ControlNode {
 public:
  ControlNode(const Params& p, lcm::LCM* lcm, StereoRig rig)
      : lcm_(lcm),
        status_(lcm, p, "ptz-control"),
        follower_(std::move(rig), controllerParamsFrom(p)),
        delay_monitor_(delayMonitorFrom(p)),
        tracks_fresh_(status_, freshnessFrom(p, "tracks"), "tracks message"),
        ch_tracks_(channel(p, channels::kObjectTracks)),
        ch_state_(channel(p, channels::kPtzState)),
        ch_setpoint_(channel(p, channels::kPtzSetpoint)),
        ch_control_state_(channel(p, channels::kControlState)) {
    tracks_ = std::make_unique<SafeSubscription<ptzstereo::object_tracks_t>>(
        *lcm_, ch_tracks_, status_,
        [this](const std::string& ch, const ptzstereo::object_tracks_t& m) { onTracks(ch, m); },
        Delivery::kNewest);
    states_ = std::make_unique<SafeSubscription<ptzstereo::ptz_state_t>>(
        *lcm_, ch_state_, status_,
        [this](const std::string& ch, const ptzstereo::ptz_state_t&) { status_.countIn(ch, -1); },
        Delivery::kNewest);
    status_.expectInput(ch_tracks_);
    reportSearch(p.getDouble("search_min_diameter_px"));
  }

  int run() { return serveUntilStopped(*lcm_, status_); }

 private:
  // The search's pattern, once: its zoom levels, what each covers, the smallest it can find.
  void reportSearch(double min_diameter_px) const {
    for (const SearchLevel& l : follower_.controller().search().levels(min_diameter_px)) {
      std::fprintf(stderr,
                   "ptz-control: search at zoom %.2f: %d %s, %.1f %% of the search region; "
                   "smallest it finds %.2f mrad (%.0f mm at 10 m)\n",
                   l.zoom, l.waypoints, l.region_share >= 1 ? "sweep ends" : "views",
                   100 * l.region_share, 1000 * l.min_angular_size_rad,
                   10000 * l.min_angular_size_rad);
    }
  }

  void onTracks(const std::string& ch, const ptzstereo::object_tracks_t& m) {
    const int64_t received = wallUtime();
    if (!tracks_fresh_.admit(ch, m.utime, m.publish_utime, m.frame_seq, received)) return;
    TracksAnswer a = follower_.follow(m);
    if (a.dropped) {
      status_.countDropped(ch, a.dropped->counter);
      log_.warn(a.dropped->counter, "ptz-control: " + a.dropped->message);
      return;
    }
    status_.countIn(ch, latencyMs(m.utime, received));
    for (const CountedEvent& e : a.events) {
      status_.increment(e.counter);
      if (!e.message.empty()) log_.warn(e.counter, "ptz-control: " + e.message);
    }
    a.setpoint.publish_utime = wallUtime();
    status_.publish(ch_setpoint_, a.setpoint, latencyMs(m.utime, a.setpoint.publish_utime));
    if (a.reason_changed) std::fprintf(stderr, "ptz-control: %s\n", a.state.reason.c_str());
    a.state.publish_utime = wallUtime();
    status_.publish(ch_control_state_, a.state, latencyMs(m.utime, a.state.publish_utime));
    status_.setCounter("kalman_outliers", follower_.controller().outliersRejected());
    // Lockstep: capture times are sim time; the delay is measured on the wall clock only.
    if (captureOnWallClock(m.utime, m.publish_utime)) {
      monitorDelay(saturatingDiffUs(a.setpoint.publish_utime, m.utime) * 1e-6);
    }
  }

  // The delay distribution and the phase margin it leaves, in the status.
  void monitorDelay(double delay_s) {
    const std::optional<DelayMonitor::Status> d = delay_monitor_.feed(delay_s);
    if (!d) return;
    status_.setCounters(d->counters);
    if (d->warning.empty()) {
      status_.setState(ptzstereo::process_status_t::STATE_OK, "");
      return;
    }
    status_.setState(ptzstereo::process_status_t::STATE_WARN, d->warning);
    log_.warn("margin", "ptz-control: " + d->warning);
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  RateLimitedLog log_;
  TracksFollower follower_;
  DelayMonitor delay_monitor_;
  FreshnessGate tracks_fresh_;
  std::string ch_tracks_, ch_state_, ch_setpoint_, ch_control_state_;
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
  addTransportParams(params);
  control::declareControlParams(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    control::ControlNode node(p, &lcm, rigFromParams(p));
    return node.run();
  });
}
