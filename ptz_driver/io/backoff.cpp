#include "ptz_driver/io/backoff.hpp"

#include <algorithm>
#include <cstdio>

namespace ptz::driver {

Backoff::Backoff(double initial_s, double max_s)
    : initial_s_(initial_s), max_s_(max_s), delay_s_(initial_s) {}

double Backoff::failed(double now_s) {
  const double wait_s = delay_s_;
  retry_at_s_ = now_s + wait_s;
  delay_s_ = std::min(2 * delay_s_, max_s_);
  return wait_s;
}

std::string secondsText(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", s);
  return buf;
}

}  // namespace ptz::driver
