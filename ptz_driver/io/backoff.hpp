// When to try again after a device or source failed: the first retry initial_s after the
// failure, every failed attempt doubles the wait up to max_s, a success starts over. Explicit
// time: the caller asks whether a retry is due (ptz-camera's sources, the serial lines).
#pragma once

#include <string>

namespace ptz::driver {

class Backoff {
 public:
  Backoff(double initial_s, double max_s);

  // Failed (or gave up) at now_s: the next attempt is due after the current wait, which then
  // doubles. Returns that wait.
  double failed(double now_s);
  // It worked: the next failure waits initial_s again.
  void succeeded() { delay_s_ = initial_s_; }
  bool due(double now_s) const { return now_s >= retry_at_s_; }
  double retryAtS() const { return retry_at_s_; }
  // The wait after the next failure.
  double nextDelayS() const { return delay_s_; }

 private:
  double initial_s_, max_s_, delay_s_;
  double retry_at_s_ = -1e300;  // due at once
};

// "1.5 s": a wait or an age for messages.
std::string secondsText(double s);

}  // namespace ptz::driver
