#include "ptz_driver/heads/onvif/head/onvif_head.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <utility>

#include "common/config.hpp"
#include "common/measure.hpp"

namespace ptz::driver {
namespace {

// After a failed start-up the camera is asked again this much later, twice as long after each
// failure up to the most (a camera coming up is found at once, a refusing one not flooded).
constexpr double kFirstRetryS = 0.1, kMaxRetryS = 1.0;

constexpr double kRateSmoothingS = 0.1;

// Closer than a camera resolves (1e-6 of the generic space is ~5e-6 rad of a 340 deg pan).
bool samePose(const PtzPose& a, const PtzPose& b) {
  return std::abs(a.pan_rad - b.pan_rad) < 1e-7 && std::abs(a.tilt_rad - b.tilt_rad) < 1e-7 &&
         std::abs(a.zoom - b.zoom) < 1e-7;
}

}  // namespace

OnvifHead::OnvifHead(OnvifModel model, OnvifHeadSettings settings, std::function<double()> now_s)
    : model_(std::move(model)), settings_(std::move(settings)), now_s_(std::move(now_s)) {
  if (!now_s_) now_s_ = [] { return wallUtime() * 1e-6; };
  event_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (event_fd_ < 0) throw std::runtime_error("ONVIF head: eventfd failed");
}

OnvifHead::~OnvifHead() {
  {
    std::lock_guard<std::mutex> lk(lock_);
    quit_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();  // at most one request's timeout
  ::close(event_fd_);
}

void OnvifHead::start(double now_s) {
  (void)now_s;
  if (!worker_.joinable()) worker_ = std::thread([this] { work(); });
}

void OnvifHead::command(const PtzPose& pose, double now_s) {
  // Continuous mode: the target's rate, fed forward. The driver commands every tick, the
  // setpoints change at the frame rate: the rate is smoothed over about kRateSmoothingS.
  const double dt = now_s - last_command_s_;
  if (last_command_ && dt > 0 && dt < 0.5) {
    const double a = dt / (kRateSmoothingS + dt);
    pan_rate_filtered_ += a * ((pose.pan_rad - last_command_->pan_rad) / dt - pan_rate_filtered_);
    tilt_rate_filtered_ +=
        a * ((pose.tilt_rad - last_command_->tilt_rad) / dt - tilt_rate_filtered_);
  } else {
    pan_rate_filtered_ = tilt_rate_filtered_ = 0;
  }
  last_command_ = pose;
  last_command_s_ = now_s;
  std::lock_guard<std::mutex> lk(lock_);
  setpoint_ = pose;  // replaces one the worker has not sent yet
  pan_rate_rad_s_ = pan_rate_filtered_;
  tilt_rate_rad_s_ = tilt_rate_filtered_;
  wake_.notify_all();
}

bool OnvifHead::stop(double now_s, double timeout_s) {
  (void)now_s;
  std::unique_lock<std::mutex> lk(lock_);
  setpoint_.reset();  // nothing moves the head after the stop
  last_command_.reset();
  if (!worker_.joinable()) return false;
  const int64_t id = ++stops_asked_;
  wake_.notify_all();
  const bool done = wake_.wait_for(lk, std::chrono::duration<double>(std::max(0.0, timeout_s)),
                                   [&] { return stops_done_ >= id || quit_; });
  return done && stops_done_ >= id && stop_confirmed_;
}

void OnvifHead::inquire(double now_s, double timeout_s) {
  (void)timeout_s;  // the session's own timeout_ms bounds every request
  // 0.8: a driver ticking at the status rate asks every tick despite its jitter.
  if (now_s - last_inquiry_s_ < 0.8 / settings_.status_rate_hz) return;
  last_inquiry_s_ = now_s;
  std::lock_guard<std::mutex> lk(lock_);
  status_wanted_ = true;
  wake_.notify_all();
}

void OnvifHead::post(Event e) {
  events_.push_back(std::move(e));
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(event_fd_, &one, sizeof one);
}

void OnvifHead::receive(double now_s) {
  (void)now_s;
  uint64_t count = 0;
  [[maybe_unused]] const ssize_t n = ::read(event_fd_, &count, sizeof count);
  std::vector<Event> events;
  {
    std::lock_guard<std::mutex> lk(lock_);
    events.swap(events_);
  }
  for (Event& e : events) {
    stats_.sent += e.sent;
    if (!e.outcome.ok()) {
      switch (e.outcome.failure) {
        case OnvifFailure::kTimeout:
        case OnvifFailure::kTransport:  // no answer: refused, closed, unreachable
          ++stats_.timeouts;
          break;
        case OnvifFailure::kMalformed:
          ++stats_.malformed;
          break;
        default:
          ++stats_.errors;
          break;
      }
      stats_.last_error = e.outcome.text;
      error_ = e.outcome.text;
      ready_ = false;
      continue;
    }
    ++stats_.replies;
    if (e.started) {
      ready_ = true;
      error_.clear();
      profile_ = e.profile;
    }
    clock_offset_s_ = e.clock_offset_s;
    if (e.status) {
      measured_ = e.status->pose;
      measured_at_s_ = e.status->at_s;
      stats_.round_trip_ms.push_back(e.status->round_trip_ms);
    }
  }
}

std::string OnvifHead::problem(double now_s) const {
  (void)now_s;
  if (ready_) return "";
  const std::string who = "ONVIF camera " + settings_.url + ": ";
  if (!error_.empty()) return who + error_;
  return who + (worker_.joinable() ? "starting (no answer yet)" : "not started");
}

void OnvifHead::work() {
  OnvifSession session(model_, settings_, now_s_);
  bool continuous = false;  // as the camera's start-up decided (move_mode, its spaces)
  bool up = false;          // the start-up done and nothing failed since
  // The last AbsoluteMove the camera took: the driver commands every tick, the camera hears
  // only what changed (again after a stop or a failure).
  PtzPose last_move;
  bool moved = false;  // last_move holds one
  double retry_s = kFirstRetryS;
  std::unique_lock<std::mutex> lk(lock_);
  // Runs one request unlocked and hands its outcome over; false (and down) when it failed.
  auto run = [&](auto request, bool starting = false, const OnvifStatus* status = nullptr) {
    const int64_t before = session.requests();
    lk.unlock();
    Event e;
    e.outcome = request();
    lk.lock();
    e.started = starting;
    if (status && e.outcome.ok()) e.status = *status;
    e.sent = session.requests() - before;
    e.clock_offset_s = session.clockOffsetS();
    e.profile = session.profileToken();
    const bool ok = e.outcome.ok();
    post(std::move(e));
    if (!ok) {
      up = false;
      setpoint_.reset();  // no move goes out until the camera answers again
      moved = false;
    }
    return ok;
  };
  while (!quit_) {
    if (stops_asked_ != stops_done_) {
      const int64_t asked = stops_asked_;
      const bool ok = up && run([&] { return session.stop(); });
      moved = false;
      stops_done_ = asked;
      stop_confirmed_ = ok;
      wake_.notify_all();
      continue;
    }
    if (!up) {
      up = run([&] { return session.start(); }, true);
      continuous = session.continuousMoves();
      if (!up) {
        wake_.wait_for(lk, std::chrono::duration<double>(retry_s),
                       [&] { return quit_ || stops_asked_ != stops_done_; });
        retry_s = std::min(2 * retry_s, kMaxRetryS);
      } else {
        retry_s = kFirstRetryS;
      }
      continue;
    }
    wake_.wait(lk, [&] {
      return quit_ || stops_asked_ != stops_done_ || status_wanted_ || (!continuous && setpoint_);
    });
    if (quit_ || stops_asked_ != stops_done_) continue;
    if (!continuous && setpoint_) {
      const PtzPose pose = *setpoint_;
      setpoint_.reset();
      if (!moved || !samePose(last_move, pose)) {
        if (!run([&] { return session.absoluteMove(pose); })) continue;
        last_move = pose;
        moved = true;
      }
    }
    if (status_wanted_) {
      status_wanted_ = false;
      OnvifStatus s;
      if (!run([&] { return session.status(&s); }, false, &s)) continue;
      // Continuous: the velocity toward the target from where the head is now.
      if (continuous && setpoint_) {
        const PtzPose target = *setpoint_;
        const double pan_rate = pan_rate_rad_s_, tilt_rate = tilt_rate_rad_s_;
        run([&] { return session.continuousMove(target, s.pose, pan_rate, tilt_rate); });
      }
    }
  }
}

std::string onvifHeadPassword(const std::string& file) {
  return onvif::passwordFromFileOrEnv(file, "PTZ_ONVIF_PASSWORD");
}

}  // namespace ptz::driver
