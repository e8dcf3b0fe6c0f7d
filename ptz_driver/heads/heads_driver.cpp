#include "ptz_driver/heads/heads_driver.hpp"

#include <algorithm>
#include <cmath>

#include "common/freshness.hpp"
#include "ptz_driver/heads/head_factory.hpp"
#include "ptzstereo/process_status_t.hpp"

namespace ptz::driver {
namespace {

double clampAxis(double v, const AxisParams& a) {
  return std::clamp(v, a.min_position, a.max_position);
}

ptzstereo::ptz_head_state_t headState(const PtzPose& p) {
  ptzstereo::ptz_head_state_t h{};
  h.pan_rad = p.pan_rad;
  h.tilt_rad = p.tilt_rad;
  h.zoom = p.zoom;
  return h;
}

}  // namespace

void declareDriverParams(Params& p) {
  addAxisLimitParams(p);  // the limits every setpoint is clamped to
  declareBackendParams(p);
  p.add("state_rate_hz", 50.0, "Hz", "position inquiries and PTZ_STATE per second",
        Range::between(1, 1000));
  p.add("inquiry_timeout_s", 0.1, "s", "ask again when an inquiry is not answered in this time",
        Range::above(0));
  p.add("setpoint_capture_clock", "wall",
        "wall: a setpoint's frame capture time is judged on the wall clock (real cameras); auto: "
        "capture times on another clock (a lockstep ptz-sim's) are judged by the publish time "
        "alone");
  p.add("deadman_s", 0.25, "s", "without a fresh setpoint for this long the heads hold",
        Range::above(0));
  addFreshnessParams(p, "setpoint", 500.0, "a PTZ_SETPOINT (by the capture time of its frame)");
  p.add("max_setpoint_rate", 3.0, "rad/s", "commanded pan/tilt change at most this fast",
        Range::above(0));
}

HeadsDriver::Settings HeadsDriver::Settings::fromParams(const Params& p) {
  return {axisLimitsFrom(p), p.getDouble("inquiry_timeout_s"), p.getDouble("deadman_s"),
          p.getDouble("max_setpoint_rate")};
}

HeadsDriver::HeadsDriver(std::array<std::unique_ptr<PtzHead>, 2> heads, const Settings& settings)
    : settings_(settings),
      heads_(std::move(heads)),
      commands_{SlewedCommand(settings.max_setpoint_rate),
                SlewedCommand(settings.max_setpoint_rate)} {}

void HeadsDriver::start(double now_s) {
  for (auto& h : heads_) h->start(now_s);
}

void HeadsDriver::receive(double now_s) {
  for (auto& h : heads_) h->receive(now_s);
}

bool HeadsDriver::acceptSetpoint(const ptzstereo::ptz_setpoint_t& m, double now_s) {
  const std::array<ptzstereo::ptz_head_setpoint_t, 2> heads = {m.left, m.right};
  for (const auto& h : heads) {
    if (!std::isfinite(h.pan_rad) || !std::isfinite(h.tilt_rad) || !std::isfinite(h.zoom)) {
      return false;
    }
  }
  const auto& axis = settings_.limits.axis;
  for (size_t i = 0; i < 2; ++i) {
    target_[i] = PtzPose{clampAxis(heads[i].pan_rad, axis[0]),
                         clampAxis(heads[i].tilt_rad, axis[1]), clampAxis(heads[i].zoom, axis[2])};
  }
  last_setpoint_s_ = now_s;
  last_setpoint_utime_ = m.utime;
  holding_ = false;
  return true;
}

bool HeadsDriver::tick(double now_s, double period_s) {
  // Deadman: no fresh setpoint -> the heads stop where they are measured, once.
  const bool hold = target_[0] && !holding_ && now_s - last_setpoint_s_ > settings_.deadman_s;
  if (hold) {
    holding_ = true;
    for (size_t i = 0; i < 2; ++i) {
      target_[i].reset();  // the hold is the target until a fresh setpoint
      if (!commands_[i].hold(heads_[i]->measured())) {
        heads_[i]->stop(now_s, 0.03);  // where it is is unknown: stop it there
      }
    }
  }
  for (size_t i = 0; i < 2; ++i) {
    if (target_[i]) commands_[i].setTarget(*target_[i]);
    const auto measured = heads_[i]->measured();
    if (const auto c = commands_[i].step(measured, period_s)) {
      heads_[i]->command(*c, now_s);
    } else if (commands_[i].hasTarget()) {
      heads_[i]->findPosition(now_s);
    }
    heads_[i]->inquire(now_s, settings_.inquiry_timeout_s);
  }
  return hold;
}

std::optional<ptzstereo::ptz_state_t> HeadsDriver::newState() {
  const auto l = heads_[0]->measured(), r = heads_[1]->measured();
  if (!l || !r) return std::nullopt;
  const double t = std::min(heads_[0]->measuredAtS(), heads_[1]->measuredAtS());
  if (t <= last_state_s_) return std::nullopt;  // nothing new
  last_state_s_ = t;
  ptzstereo::ptz_state_t msg{};
  msg.utime = static_cast<int64_t>(t * 1e6);
  msg.left = headState(*l);
  msg.right = headState(*r);
  msg.setpoint_utime = last_setpoint_utime_;
  return msg;
}

HeadsReport HeadsDriver::report(double now_s) {
  HeadsReport r;
  int64_t timeouts = 0, errors = 0, buffer_full = 0, malformed = 0, late = 0, reopens = 0;
  for (auto& h : heads_) {
    auto& s = h->stats();
    r.round_trip_ms.insert(r.round_trip_ms.end(), s.round_trip_ms.begin(), s.round_trip_ms.end());
    s.round_trip_ms.clear();
    timeouts += s.timeouts;
    errors += s.errors;
    buffer_full += s.buffer_full;
    malformed += s.malformed;
    late += s.late_replies;
    reopens += s.reopens;
    if (!s.last_error.empty()) r.head_errors.push_back(s.last_error);
  }
  const bool up = heads_[0]->measured() && heads_[1]->measured() &&
                  now_s - std::min(heads_[0]->measuredAtS(), heads_[1]->measuredAtS()) < 1.0;
  const bool estimated = !heads_[0]->measuresPosition() || !heads_[1]->measuresPosition();
  r.counters = {{"head_timeouts", timeouts},
                {"head_errors", errors},
                {"head_buffer_full", buffer_full},
                {"head_malformed", malformed},
                {"head_late_replies", late},
                {"head_reopens", reopens},
                {"position_estimated", estimated ? 1 : 0}};
  std::string problem;  // e.g. a serial port closed until its next reopen attempt
  for (auto& h : heads_) {
    if (problem.empty()) problem = h->problem(now_s);
  }
  if (!up) {
    r.state = ptzstereo::process_status_t::STATE_ERROR;
    r.message = problem.empty() ? "no position replies from a head for 1 s" : problem;
  } else if (estimated) {
    r.state = ptzstereo::process_status_t::STATE_WARN;
    r.message = "a head cannot report its position: PTZ_STATE is estimated";
  } else {
    r.state = ptzstereo::process_status_t::STATE_OK;
  }
  return r;
}

}  // namespace ptz::driver
