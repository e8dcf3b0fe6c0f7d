// ptz-driver: PTZ_SETPOINT -> the heads' motors -> PTZ_STATE, for real heads (VISCA over IP or
// serial, Pelco-D, GPIO, ONVIF; the simulator can pose as VISCA-over-IP or ONVIF cameras with
// --visca-port or --onvif-port), built by backend in head_factory. Safety whatever arrives:
// setpoints are clamped to the limits and slewed at most max_setpoint_rate, stale ones are
// dropped, without a fresh one for deadman_s the heads hold where they are, and they stop on
// exit (SIGINT/SIGTERM, or an exception out of the loop). The rules are HeadsDriver's; this
// loop waits on LCM and the heads.
#include <poll.h>

#include <algorithm>
#include <memory>

#include "common/freshness.hpp"
#include "common/transport/intake.hpp"
#include "common/transport/transport.hpp"
#include "ptz_driver/emulators/emulated_gpio_wiring.hpp"  // gpio_chip "sim"
#include "ptz_driver/heads/common/heads_stop.hpp"
#include "ptz_driver/heads/head_factory.hpp"
#include "ptz_driver/heads/heads_driver.hpp"
#include "ptz_driver/heads/onvif/discovery/discover_command.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"

namespace ptz::driver {
namespace {

CaptureClock setpointClock(const Params& p) {
  const std::string clock = p.getString("setpoint_capture_clock");
  if (clock != "wall" && clock != "auto") {
    throw p.invalid("setpoint_capture_clock", "must be wall or auto");
  }
  return clock == "wall" ? CaptureClock::kWall : CaptureClock::kAuto;
}

class DriverNode {
 public:
  DriverNode(const Params& p, lcm::LCM* lcm)
      : lcm_(lcm),
        status_(lcm, p, "ptz-driver"),
        period_s_(1.0 / p.getDouble("state_rate_hz")),
        // Heads run on the wall clock: a setpoint's capture time is judged on it too (but for a
        // lockstep simulator's, setpoint_capture_clock auto).
        setpoint_gate_(status_, freshnessFrom(p, "setpoint"), "setpoint", "setpoint_",
                       setpointClock(p)),
        ch_setpoint_(channel(p, channels::kPtzSetpoint)),
        ch_state_(channel(p, channels::kPtzState)),
        driver_(makeHeads(p, openHeadLinesOrEmulated), HeadsDriver::Settings::fromParams(p)) {
    setpoints_ = std::make_unique<SafeSubscription<ptzstereo::ptz_setpoint_t>>(
        *lcm_, ch_setpoint_, status_,
        [this](const std::string& ch, const ptzstereo::ptz_setpoint_t& m) { onSetpoint(ch, m); },
        Delivery::kNewest);
    status_.expectInput(ch_setpoint_);
  }

  int run() {
    // Motion stops on exit, also when an exception leaves this loop.
    HeadsStop stopper(
        {&driver_.head(0), &driver_.head(1)}, 0.3, &DriverNode::nowS, [this](size_t i) {
          const std::string side = i == 0 ? "left" : "right";
          log_.warn("stop_" + side, "ptz-driver: the " + side + " head did not confirm the stop");
        });
    driver_.start(nowS());
    status_.publishNow();
    double next_tick = nowS();
    while (!StopFlag::stopRequested()) {
      // A head without a descriptor (fd -1) is skipped by poll.
      pollfd fds[3] = {{lcm_->getFileno(), POLLIN, 0},
                       {driver_.head(0).fd(), POLLIN, 0},
                       {driver_.head(1).fd(), POLLIN, 0}};
      const int wait_ms = std::max(0, static_cast<int>((next_tick - nowS()) * 1000));
      ::poll(fds, 3, wait_ms);
      if (fds[0].revents & POLLIN) handleNewest(*lcm_, 0);
      driver_.receive(nowS());
      if (nowS() >= next_tick) {
        tick();
        next_tick += period_s_;
        if (next_tick < nowS()) next_tick = nowS() + period_s_;  // fell behind: do not burst
      }
      status_.maybePublish();
    }
    stopper.stop();
    status_.publishLast();
    return 0;
  }

 private:
  static double nowS() { return wallUtime() * 1e-6; }

  void onSetpoint(const std::string& ch, const ptzstereo::ptz_setpoint_t& m) {
    const int64_t received = wallUtime();
    if (!setpoint_gate_.admit(ch, m.utime, m.publish_utime, m.frame_seq, received)) return;
    if (!driver_.acceptSetpoint(m, received * 1e-6)) {
      status_.countDropped(ch, "nonfinite");
      log_.warn("nonfinite", "ptz-driver: setpoint with non-finite values dropped");
      return;
    }
    status_.countIn(ch, (received - m.publish_utime) / 1000.0);
  }

  void tick() {
    if (driver_.tick(nowS(), period_s_)) {
      status_.increment("deadman_holds");
      log_.warn("deadman", "ptz-driver: no fresh setpoint; holding");
    }
    if (auto state = driver_.newState()) {
      state->publish_utime = wallUtime();
      status_.publish(ch_state_, *state, (state->publish_utime - state->utime) / 1000.0);
    }
    HeadsReport r = driver_.report(nowS());
    for (const auto& e : r.head_errors) log_.warn("head_error", "ptz-driver: head error: " + e);
    rtt_ms_.insert(rtt_ms_.end(), r.round_trip_ms.begin(), r.round_trip_ms.end());
    status_.setPercentilesUs("head_round_trip", &rtt_ms_, 50);
    status_.setCounters(r.counters);
    status_.setState(r.state, r.message);
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  RateLimitedLog log_;
  double period_s_;
  FreshnessGate setpoint_gate_;
  std::string ch_setpoint_, ch_state_;
  HeadsDriver driver_;
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_setpoint_t>> setpoints_;
  std::vector<double> rtt_ms_;
};

}  // namespace
}  // namespace ptz::driver

int main(int argc, char** argv) {
  using namespace ptz;
  Params params(
      "ptz-driver",
      "Drives real PTZ heads from PTZ_SETPOINT and publishes their measured "
      "PTZ_STATE (VISCA over IP or serial, Pelco-D, GPIO DC motors, ONVIF), with limits, rate "
      "limits, a deadman and stale-"
      "setpoint dropping.");
  addTransportParams(params);
  driver::declareDriverParams(params);
  driver::declareDiscoverParams(params);
  // --discover finds ONVIF cameras and exits, without LCM.
  if (const auto code = driver::runDiscoverIfAsked(argc, argv, params)) return *code;
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    driver::DriverNode node(p, &lcm);
    return node.run();
  });
}
