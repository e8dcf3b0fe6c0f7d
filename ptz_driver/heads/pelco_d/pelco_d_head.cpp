#include "ptz_driver/heads/pelco_d/pelco_d_head.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "ptz_driver/heads/pelco_d/pelco_d.hpp"

namespace ptz::driver {
namespace {
constexpr uint8_t kReplyOf[3] = {0x59, 0x5B, 0x5D};  // pan, tilt, zoom position

// Long enough for the longest move at the rate limit, then five time constants of settling.
double homingTimeS(const PtzPlant::Params& p) {
  double t = 0;
  for (const AxisParams& a : p.axis) {
    const double range = a.max_position - a.min_position;
    t = std::max(t, a.dead_time_s + range / a.max_rate_per_s + 5 * a.time_constant_s);
  }
  return t;
}

PtzPose home(const PtzPlant::Params& p) {
  auto within = [](double v, const AxisParams& a) {
    return std::clamp(v, a.min_position, a.max_position);
  };
  return {within(0.0, p.axis[0]), within(0.0, p.axis[1]), within(1.0, p.axis[2])};
}
}  // namespace

PelcoDHead::PelcoDHead(PelcoModel model, std::shared_ptr<PelcoDLine> line, int address,
                       bool position_query, const PtzPlant::Params& plant)
    : model_(std::move(model)),
      line_(std::move(line)),
      address_(address),
      position_query_(position_query),
      plant_(plant),
      estimate_{Pt1Axis(plant.axis[0], home(plant).pan_rad),
                Pt1Axis(plant.axis[1], home(plant).tilt_rad),
                Pt1Axis(plant.axis[2], home(plant).zoom)} {
  line_->attach(address);
}

bool PelcoDHead::send(const Bytes& frame) {
  if (!line_->send(frame)) return false;
  ++book_.stats().sent;
  return true;
}

void PelcoDHead::start(double now_s) {
  start_s_ = now_s;
  if (position_query_) return;  // it will say where it is
  sendHome(now_s);
}

void PelcoDHead::sendHome(double now_s) {
  // Where the head is is unknown: send it home; the estimate holds once it must be there.
  book_.forgetSent();
  wanted_ = home(plant_);
  position_unknown_ = !sendCommands(now_s);  // the port closed: again at the next call
  line_->talked(address_);
  homed_at_s_ = now_s + homingTimeS(plant_);
}

void PelcoDHead::followReopen() {
  if (line_->reopens() == line_reopens_) return;
  line_reopens_ = line_->reopens();
  book_.lostTrack();
  wanted_.reset();
  query_.reset();
  next_query_.reset();
  // Without queries nothing says where the head went meanwhile (moved by hand, power cycled).
  if (!position_query_ && homed_at_s_ >= 0) position_unknown_ = true;
}

void PelcoDHead::command(const PtzPose& pose, double now_s) {
  followReopen();
  if (position_unknown_) {  // where it is is unknown: home first, then the poses
    sendHome(now_s);
    return;
  }
  wanted_ = pose;
  service(now_s);
}

void PelcoDHead::findPosition(double now_s) {
  followReopen();
  if (position_unknown_) sendHome(now_s);
}

void PelcoDHead::service(double now_s) {
  const bool command_waiting =
      wanted_ && (book_.changed(HeadBook::kPan, model_.panCentideg(wanted_->pan_rad)) ||
                  book_.changed(HeadBook::kTilt, model_.tiltCentideg(wanted_->tilt_rad)) ||
                  book_.changed(HeadBook::kZoom, model_.zoom.position(wanted_->zoom)));
  const bool query_waiting = next_query_ && !query_;
  if (!command_waiting && !query_waiting) {
    line_->doesNotWant(address_);
    return;
  }
  if (!line_->mayTalk(address_, now_s)) return;
  if (command_waiting && (command_turn_ || !query_waiting)) {
    sendCommands(now_s);
    command_turn_ = false;
  } else {
    sendQuery(now_s);
    command_turn_ = true;
  }
  line_->talked(address_);
}

bool PelcoDHead::sendCommands(double now_s) {
  const int pan = model_.panCentideg(wanted_->pan_rad);
  const int tilt = model_.tiltCentideg(wanted_->tilt_rad);
  const int zoom = model_.zoom.position(wanted_->zoom);
  const int units[3] = {pan, tilt, zoom};
  // What the head will do with each value, in the plant model's units (for the estimate).
  const double as_taken[3] = {model_.panRad(pan), model_.tiltRad(tilt), model_.zoom.ratio(zoom)};
  for (const HeadBook::Axis a : {HeadBook::kPan, HeadBook::kTilt, HeadBook::kZoom}) {
    if (!book_.changed(a, units[a])) continue;
    const Bytes frame = a == HeadBook::kPan    ? pelco_d::setPanPosition(address_, pan)
                        : a == HeadBook::kTilt ? pelco_d::setTiltPosition(address_, tilt)
                                               : pelco_d::setZoomPosition(address_, zoom);
    if (!send(frame)) return false;
    book_.sent(a, units[a]);
    if (!position_query_) estimate_[a].command(sinceStartS(now_s), as_taken[a]);
  }
  return true;
}

void PelcoDHead::sendQuery(double now_s) {
  const HeadBook::Axis a = *next_query_;
  const Bytes frame = a == HeadBook::kPan    ? pelco_d::queryPan(address_)
                      : a == HeadBook::kTilt ? pelco_d::queryTilt(address_)
                                             : pelco_d::queryZoom(address_);
  if (!send(frame)) return;
  query_ = a;
  next_query_.reset();
  query_sent_s_ = now_s;
  line_->awaitReply(address_, now_s + timeout_s_);
}

bool PelcoDHead::stop(double now_s, double timeout_s) {
  book_.forgetSent();
  wanted_.reset();
  next_query_.reset();  // nothing but the stop goes now
  if (!position_query_ && homed_at_s_ >= 0 && now_s < homed_at_s_) {
    // Stopped somewhere between where it was and home: where is unknown.
    position_unknown_ = true;
  } else if (!position_query_) {  // the estimate stops where it has got to
    estimateTo(now_s);
    for (Pt1Axis& a : estimate_) a.command(sinceStartS(now_s), a.position());
  }
  // Half duplex: a stop sent into a reply on its way collides with it and is lost unnoticed,
  // so wait (reading replies) for the bus to be free. The waits run on the caller's clock.
  const auto start = std::chrono::steady_clock::now();
  auto now = [&] {
    return now_s + std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  const bool was_free = waitUntil(
      line_->fd(), timeout_s, [&] { read(now()); }, [&] { return line_->free(now()); });
  // Sent anyway when the bus stays busy: a stop that may collide beats none. Twice, as nothing
  // confirms it and one frame may still be garbled.
  const Bytes frame = pelco_d::stop(address_);
  if (!send(frame) || !send(frame)) return false;
  line_->talked(address_);
  const double left_s = timeout_s - (now() - now_s);
  return waitUntil(
             -1, left_s, [] {}, [&] { return line_->idle(); }) &&
         was_free;
}

void PelcoDHead::inquire(double now_s, double timeout_s) {
  followReopen();
  timeout_s_ = timeout_s;
  if (!position_query_) {
    estimateTo(now_s);
  } else if (query_ && now_s - query_sent_s_ > timeout_s) {
    ++book_.stats().timeouts;  // no answer: the bus is free again, the round starts over
    line_->replyCame(address_);
    query_.reset();
    next_query_ = HeadBook::kPan;
  } else if (!query_ && !next_query_) {
    next_query_ = HeadBook::kPan;  // the last round is complete: the next one
  }
  service(now_s);
}

void PelcoDHead::receive(double now_s) {
  read(now_s);
  if (!position_query_) estimateTo(now_s);
  service(now_s);
}

void PelcoDHead::read(double now_s) {
  line_->pump(&book_, now_s);
  followReopen();
  while (line_->nextUnrouted()) ++book_.stats().malformed;  // from an address nobody has
  while (const auto r = line_->next(address_)) {
    if (!query_ || r->command2 != kReplyOf[*query_]) {
      ++book_.stats().malformed;  // not the answer to the question out
      continue;
    }
    ++book_.stats().replies;
    const HeadBook::Axis a = *query_;
    book_.measured(a, r->value);
    if (a == HeadBook::kPan) book_.roundTrip(query_sent_s_, now_s);
    query_.reset();  // (the line saw the reply come: the bus is free)
    if (a != HeadBook::kZoom) next_query_ = a == HeadBook::kPan ? HeadBook::kTilt : HeadBook::kZoom;
  }
}

void PelcoDHead::estimateTo(double now_s) {
  if (homed_at_s_ < 0) return;  // not started
  for (Pt1Axis& a : estimate_) a.advanceTo(sinceStartS(now_s), plant_.step_s);
  estimate_at_s_ = now_s;
}

std::optional<PtzPose> PelcoDHead::measured() const {
  if (position_query_) {
    if (!book_.hasMeasurement()) return std::nullopt;
    return PtzPose{model_.panRad(book_.measuredUnits(HeadBook::kPan)),
                   model_.tiltRad(book_.measuredUnits(HeadBook::kTilt)),
                   model_.zoom.ratio(book_.measuredUnits(HeadBook::kZoom))};
  }
  if (position_unknown_ || homed_at_s_ < 0 || estimate_at_s_ < homed_at_s_) {
    return std::nullopt;  // still homing, or stopped before home
  }
  return PtzPose{estimate_[0].position(), estimate_[1].position(), estimate_[2].position()};
}

double PelcoDHead::measuredAtS() const {
  return position_query_ ? book_.measuredAtS() : estimate_at_s_;
}

}  // namespace ptz::driver
