// ptz-driver: PTZ_SETPOINT -> the heads' motors -> PTZ_STATE, for real heads (VISCA over IP or
// serial, Pelco-D; the simulator can pose as VISCA-over-IP cameras with --visca-port), built by
// backend in head_factory. Safety whatever arrives:
// setpoints are clamped to the limits and slewed at most max_setpoint_rate, stale ones are
// dropped, without a fresh one for deadman_s the heads hold where they are, and they stop on
// exit (SIGINT/SIGTERM, or an exception out of the loop).
#include <poll.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include "common/freshness.hpp"
#include "common/plant.hpp"
#include "common/transport/transport.hpp"
#include "ptz_driver/emulators/emulated_gpio_wiring.hpp"  // gpio_chip "sim"
#include "ptz_driver/heads/head_factory.hpp"
#include "ptz_driver/heads/heads_stop.hpp"
#include "ptz_driver/heads/slewed_command.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"

namespace ptz::driver {
namespace {

void declare(Params& p) {
  addTransportParams(p);
  addAxisLimitParams(p);  // the limits every setpoint is clamped to
  declareBackendParams(p);
  p.add("state_rate_hz", 50.0, "Hz", "position inquiries and PTZ_STATE per second",
        Range::between(1, 1000));
  p.add("inquiry_timeout_s", 0.1, "s", "ask again when an inquiry is not answered in this time",
        Range::above(0));
  p.add("deadman_s", 0.25, "s", "without a fresh setpoint for this long the heads hold",
        Range::above(0));
  addFreshnessParams(p, "setpoint", 500.0, "a PTZ_SETPOINT (by the capture time of its frame)");
  p.add("max_setpoint_rate", 3.0, "rad/s", "commanded pan/tilt change at most this fast",
        Range::above(0));
}

double clampAxis(double v, const AxisParams& a) {
  return std::clamp(v, a.min_position, a.max_position);
}

class DriverNode {
 public:
  DriverNode(const Params& p, lcm::LCM* lcm)
      : p_(p),
        lcm_(lcm),
        status_(lcm, p, "ptz-driver"),
        limits_(axisLimitsFrom(p)),
        inquiry_timeout_s_(p.getDouble("inquiry_timeout_s")),
        deadman_s_(p.getDouble("deadman_s")),
        max_setpoint_rate_(p.getDouble("max_setpoint_rate")),
        setpoint_freshness_(freshnessFrom(p, "setpoint")),
        ch_setpoint_(channel(p, channels::kPtzSetpoint)),
        ch_state_(channel(p, channels::kPtzState)) {
    heads_ = makeHeads(p, openHeadLinesOrEmulated);
    setpoints_ = std::make_unique<SafeSubscription<ptzstereo::ptz_setpoint_t>>(
        *lcm_, ch_setpoint_, status_,
        [this](const std::string& ch, const ptzstereo::ptz_setpoint_t& m) { onSetpoint(ch, m); },
        Delivery::kNewest);
    status_.expectInput(ch_setpoint_);
  }

  int run() {
    const double period_s = 1.0 / p_.getDouble("state_rate_hz");
    // Motion stops on exit, also when an exception leaves this loop.
    HeadsStop stopper({heads_[0].get(), heads_[1].get()}, 0.3, &DriverNode::nowS, [this](size_t i) {
      const std::string side = i == 0 ? "left" : "right";
      log_.warn("stop_" + side, "ptz-driver: the " + side + " head did not confirm the stop");
    });
    for (auto& h : heads_) h->start(nowS());
    status_.publishNow();
    double next_tick = nowS();
    while (!StopFlag::stopRequested()) {
      // A head without a descriptor (fd -1) is skipped by poll.
      pollfd fds[3] = {{lcm_->getFileno(), POLLIN, 0},
                       {heads_[0]->fd(), POLLIN, 0},
                       {heads_[1]->fd(), POLLIN, 0}};
      const int wait_ms = std::max(0, static_cast<int>((next_tick - nowS()) * 1000));
      ::poll(fds, 3, wait_ms);
      if (fds[0].revents & POLLIN) handleNewest(*lcm_, 0);
      for (auto& h : heads_) h->receive(nowS());
      if (nowS() >= next_tick) {
        tick(period_s);
        next_tick += period_s;
        if (next_tick < nowS()) next_tick = nowS() + period_s;  // fell behind: do not burst
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
    const Freshness fresh =
        judgeFreshness(m.utime, m.publish_utime, wallUtime(), setpoint_freshness_);
    if (fresh != Freshness::kFresh) {
      status_.countDropped(ch, std::string("setpoint_") + freshnessReason(fresh));
      log_.warn("fresh", std::string("ptz-driver: dropped a ") + freshnessReason(fresh) +
                             " setpoint (frame " + std::to_string(m.frame_seq) + ")");
      return;
    }
    const std::array<ptzstereo::ptz_head_setpoint_t, 2> heads = {m.left, m.right};
    for (const auto& h : heads) {
      if (!std::isfinite(h.pan_rad) || !std::isfinite(h.tilt_rad) || !std::isfinite(h.zoom)) {
        status_.countDropped(ch, "nonfinite");
        log_.warn("nonfinite", "ptz-driver: setpoint with non-finite values dropped");
        return;
      }
    }
    status_.countIn(ch, (wallUtime() - m.publish_utime) / 1000.0);
    for (int i = 0; i < 2; ++i) {
      target_[static_cast<size_t>(i)] =
          PtzPose{clampAxis(heads[static_cast<size_t>(i)].pan_rad, limits_.axis[0]),
                  clampAxis(heads[static_cast<size_t>(i)].tilt_rad, limits_.axis[1]),
                  clampAxis(heads[static_cast<size_t>(i)].zoom, limits_.axis[2])};
    }
    last_setpoint_s_ = nowS();
    last_setpoint_utime_ = m.utime;
    holding_ = false;
  }

  void tick(double period_s) {
    const double now = nowS();
    // Deadman: no fresh setpoint -> the heads stop where they are measured, once.
    if (target_[0] && !holding_ && now - last_setpoint_s_ > deadman_s_) {
      holding_ = true;
      status_.increment("deadman_holds");
      log_.warn("deadman", "ptz-driver: no fresh setpoint; holding");
      for (size_t i = 0; i < 2; ++i) {
        target_[i].reset();  // the hold is the target until a fresh setpoint
        if (!commands_[i].hold(heads_[i]->measured())) {
          heads_[i]->stop(now, 0.03);  // where it is is unknown: stop it there
        }
      }
    }
    for (size_t i = 0; i < 2; ++i) {
      if (target_[i]) commands_[i].setTarget(*target_[i]);
      const auto measured = heads_[i]->measured();
      if (const auto c = commands_[i].step(measured, period_s)) {
        heads_[i]->command(*c, now);
      } else if (commands_[i].hasTarget()) {
        heads_[i]->findPosition(now);
      }
      heads_[i]->inquire(now, inquiry_timeout_s_);
    }
    publishState();
    report();
  }

  void publishState() {
    const auto l = heads_[0]->measured(), r = heads_[1]->measured();
    if (!l || !r) return;
    const double t = std::min(heads_[0]->measuredAtS(), heads_[1]->measuredAtS());
    if (t <= last_state_s_) return;  // nothing new
    last_state_s_ = t;
    ptzstereo::ptz_state_t msg{};
    msg.utime = static_cast<int64_t>(t * 1e6);
    auto head = [](const PtzPose& p) {
      ptzstereo::ptz_head_state_t h{};
      h.pan_rad = p.pan_rad;
      h.tilt_rad = p.tilt_rad;
      h.zoom = p.zoom;
      return h;
    };
    msg.left = head(*l);
    msg.right = head(*r);
    msg.setpoint_utime = last_setpoint_utime_;
    msg.publish_utime = wallUtime();
    status_.publish(ch_state_, msg, (msg.publish_utime - msg.utime) / 1000.0);
  }

  void report() {
    std::vector<double> rtt;
    int64_t timeouts = 0, errors = 0, buffer_full = 0, malformed = 0, late = 0, reopens = 0;
    for (auto& h : heads_) {
      auto& s = h->stats();
      rtt.insert(rtt.end(), s.round_trip_ms.begin(), s.round_trip_ms.end());
      timeouts += s.timeouts;
      errors += s.errors;
      buffer_full += s.buffer_full;
      malformed += s.malformed;
      late += s.late_replies;
      reopens += s.reopens;
      if (!s.last_error.empty()) log_.warn("head_error", "ptz-driver: head error: " + s.last_error);
    }
    rtt_ms_.insert(rtt_ms_.end(), rtt.begin(), rtt.end());
    for (auto& h : heads_) h->stats().round_trip_ms.clear();
    status_.setPercentilesUs("head_round_trip", &rtt_ms_, 50);
    status_.setCounter("head_timeouts", timeouts);
    status_.setCounter("head_errors", errors);
    status_.setCounter("head_buffer_full", buffer_full);
    status_.setCounter("head_malformed", malformed);
    status_.setCounter("head_late_replies", late);
    status_.setCounter("head_reopens", reopens);
    const bool up = heads_[0]->measured() && heads_[1]->measured() &&
                    nowS() - std::min(heads_[0]->measuredAtS(), heads_[1]->measuredAtS()) < 1.0;
    const bool estimated = !heads_[0]->measuresPosition() || !heads_[1]->measuresPosition();
    status_.setCounter("position_estimated", estimated ? 1 : 0);
    std::string problem;  // e.g. a serial port closed until its next reopen attempt
    for (auto& h : heads_) {
      if (problem.empty()) problem = h->problem(nowS());
    }
    if (!up) {
      status_.setState(ptzstereo::process_status_t::STATE_ERROR,
                       problem.empty() ? "no position replies from a head for 1 s" : problem);
    } else if (estimated) {
      status_.setState(ptzstereo::process_status_t::STATE_WARN,
                       "a head cannot report its position: PTZ_STATE is estimated");
    } else {
      status_.setState(ptzstereo::process_status_t::STATE_OK, "");
    }
  }

  const Params& p_;
  lcm::LCM* lcm_;
  StatusReporter status_;
  RateLimitedLog log_;
  PtzPlant::Params limits_;
  double inquiry_timeout_s_ = 0, deadman_s_ = 0, max_setpoint_rate_ = 0;
  FreshnessLimits setpoint_freshness_;
  std::string ch_setpoint_, ch_state_;
  std::array<std::unique_ptr<PtzHead>, 2> heads_;
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_setpoint_t>> setpoints_;
  std::array<std::optional<PtzPose>, 2> target_;  // the last fresh setpoint, until a hold
  std::array<SlewedCommand, 2> commands_{SlewedCommand(max_setpoint_rate_),
                                         SlewedCommand(max_setpoint_rate_)};
  double last_setpoint_s_ = 0, last_state_s_ = 0;
  int64_t last_setpoint_utime_ = 0;
  bool holding_ = false;
  std::vector<double> rtt_ms_;
};

}  // namespace
}  // namespace ptz::driver

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-driver",
                "Drives real PTZ heads from PTZ_SETPOINT and publishes their measured "
                "PTZ_STATE (VISCA over IP or serial, Pelco-D, GPIO DC motors), with limits, rate "
                "limits, a deadman and stale-"
                "setpoint dropping.");
  driver::declare(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    driver::DriverNode node(p, &lcm);
    return node.run();
  });
}
