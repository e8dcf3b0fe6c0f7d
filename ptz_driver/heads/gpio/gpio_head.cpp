#include "ptz_driver/heads/gpio/gpio_head.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <ctime>

namespace ptz::driver {
namespace {

double wallS() {
  using namespace std::chrono;
  return duration_cast<nanoseconds>(system_clock::now().time_since_epoch()).count() * 1e-9;
}

constexpr size_t kMaxLatenessSamples = 100000;

}  // namespace

GpioHead::GpioHead(GpioHeadConfig config, std::unique_ptr<GpioLines> lines, bool threaded)
    : config_(std::move(config)), lines_(std::move(lines)), threaded_(threaded) {
  axes_[0] = std::make_unique<GpioAxis>(config_.pan, *lines_);
  axes_[1] = std::make_unique<GpioAxis>(config_.tilt, *lines_);
  if (threaded_) thread_ = std::thread([this] { run(); });
}

GpioHead::~GpioHead() {
  quit_ = true;
  if (thread_.joinable()) thread_.join();
  for (auto& a : axes_) a->stop();
}

double GpioHead::nowS(double given_s) const {
  return threaded_ ? gpioClockS() : given_s;
}

void GpioHead::start(double now_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& a : axes_) a->startHoming(nowS(now_s));
}

void GpioHead::command(const PtzPose& pose, double) {
  std::lock_guard<std::mutex> lock(mutex_);
  axes_[0]->setTarget(pose.pan_rad);
  axes_[1]->setTarget(pose.tilt_rad);
}

bool GpioHead::stop(double, double) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& a : axes_) a->stop();
  return true;  // the lines are written: nothing to confirm
}

std::optional<PtzPose> GpioHead::measured() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!axes_[0]->homed() || !axes_[1]->homed()) return std::nullopt;
  return PtzPose{axes_[0]->positionRad(), axes_[1]->positionRad(), config_.zoom};
}

double GpioHead::measuredAtS() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return measured_at_s_;
}

HeadStats& GpioHead::stats() {
  std::lock_guard<std::mutex> lock(mutex_);
  stats_.malformed = axes_[0]->illegalTransitions() + axes_[1]->illegalTransitions();
  const int64_t io_errors = lines_->ioErrors();
  stats_.errors = io_errors;
  stats_.last_error.clear();
  for (const auto& a : axes_) {
    if (a->error().empty()) continue;  // a failed or interrupted homing: it needs a restart
    ++stats_.errors;
    stats_.last_error = config_.name + " " + a->error();
  }
  if (stats_.last_error.empty() && io_errors > 0)
    stats_.last_error =
        config_.name + ": " + std::to_string(io_errors) + " GPIO reads/writes failed";
  return stats_;
}

double GpioHead::step(double now_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  events_.clear();
  lines_->readEvents(&events_);
  for (const auto& e : events_) {
    if (!axes_[0]->handle(e) && !axes_[1]->handle(e)) ++foreign_events_;
  }
  const double next_s = std::min(axes_[0]->step(now_s), axes_[1]->step(now_s));
  // The driver stamps PTZ_STATE on the wall clock.
  measured_at_s_ = threaded_ ? now_s + (wallS() - gpioClockS()) : now_s;
  return next_s;
}

GpioAxis::State GpioHead::state(int axis) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return axes_.at(static_cast<size_t>(axis))->state();
}

double GpioHead::positionRad(int axis) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto& a = axes_.at(static_cast<size_t>(axis));
  return a->homed() ? a->positionRad() : a->counts() / a->config().counts_per_rad;
}

std::vector<double> GpioHead::takeWakeLatenessS() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<double> out;
  out.swap(lateness_s_);
  return out;
}

std::vector<double> GpioHead::takeEdgeErrorBoundsS() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<double> out;
  out.swap(edge_error_bound_s_);
  return out;
}

// Sleeps until each step is due, minus the median lateness of a wake-up (learnt as it goes: a
// microsecond up when late, down when early, so that stalls do not pull it), so that PWM edges
// land on time as often late as early; a step woken early runs for the time it was due.
bool GpioHead::waitForStep(const std::function<bool()>& done, double timeout_s) const {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  std::unique_lock<std::mutex> lock(step_mutex_);
  while (!done()) {
    if (stepped_.wait_until(lock, end) == std::cv_status::timeout) return done();
  }
  return true;
}

void GpioHead::run() {
  const double max_lead_s = 0.25 / std::max(config_.pan.pwm_hz, config_.tilt.pwm_hz);
  double due_s = gpioClockS(), lead_s = 0;
  while (!quit_) {
    const double now_s = gpioClockS();
    lead_s = std::clamp(lead_s + (now_s > due_s ? 1e-6 : -1e-6), 0.0, max_lead_s);
    const double next_s = step(std::max(now_s, due_s));
    const double done_s = gpioClockS();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (lateness_s_.size() < kMaxLatenessSamples) {
        lateness_s_.push_back(now_s - due_s);
        edge_error_bound_s_.push_back(std::max({done_s - due_s, due_s - now_s, 0.0}));
      }
    }
    {
      std::lock_guard<std::mutex> lock(step_mutex_);  // a waiter between look and wait hears it
    }
    stepped_.notify_all();
    due_s = next_s;
    gpioSleepUntilS(due_s - lead_s);
  }
}

}  // namespace ptz::driver
