#include "common/measure.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>

namespace ptz {

int64_t wallUtime() {
  using namespace std::chrono;
  return duration_cast<microseconds>(system_clock::now().time_since_epoch()).count();
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * (v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(rank));
  std::nth_element(v.begin(), v.begin() + static_cast<ptrdiff_t>(lo), v.end());
  const double a = v[lo];
  if (lo + 1 >= v.size()) return a;
  const double b = *std::min_element(v.begin() + static_cast<ptrdiff_t>(lo) + 1, v.end());
  return a + (rank - lo) * (b - a);
}

RateSchedule::RateSchedule(double rate_hz) {
  if (rate_hz > 0) period_us_ = std::max<int64_t>(1, std::llround(1e6 / rate_hz));
}

bool RateSchedule::take(int64_t utime) {
  if (!enabled()) return false;
  const bool restart = !started_ || utime < last_utime_;
  // A hundredth of the period early still counts: capture times jitter.
  if (!restart && utime < next_due_utime_ - period_us_ / 100) return false;
  // Capture times may come from outside (a message, a timestamp file): no overflow near the ends.
  const auto plus_period = [this](int64_t t) {
    int64_t sum;
    return __builtin_add_overflow(t, period_us_, &sum) ? std::numeric_limits<int64_t>::max() : sum;
  };
  next_due_utime_ = restart ? utime : plus_period(next_due_utime_);
  if (next_due_utime_ <= utime) next_due_utime_ = plus_period(utime);
  started_ = true;
  last_utime_ = utime;
  return true;
}

std::string printable(const std::string& text, size_t max_chars) {
  std::string out;
  for (unsigned char c : text) {
    if (out.size() >= max_chars) {
      out += "...";
      break;
    }
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out;
}

std::string formatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace ptz
