// What every part measures with, LCM or not: the wall clock messages are stamped in, and
// percentiles of samples (medians and p99 in statuses and benchmarks).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ptz {

// Wall clock, microseconds since the Unix epoch.
int64_t wallUtime();

// Percentile of a sample set (p in [0, 100], interpolated between ranks); NaN when empty.
double percentile(std::vector<double> values, double p);

// Picks samples at a fixed rate from a stream stamped in capture time, on a schedule rather than
// a period after the last pick: 5 Hz from 30 Hz frames is every 6th frame, though 6 x 33.333 ms
// falls 2 us short of 0.2 s. A time that goes back (a restarted source) or a silence longer than
// the period starts the schedule again. Rate 0: never.
class RateSchedule {
 public:
  explicit RateSchedule(double rate_hz);
  bool enabled() const { return period_us_ > 0; }
  // Whether the sample at utime is taken (the schedule then moves on).
  bool take(int64_t utime);

 private:
  int64_t period_us_ = 0;
  int64_t last_utime_ = 0;
  int64_t next_due_utime_ = 0;
  bool started_ = false;
};

// Text from outside (another process, a log) made safe to print on one line: control characters
// escaped, at most max_chars.
std::string printable(const std::string& text, size_t max_chars = 200);

// A number as printf's %g writes it (six significant digits), for messages.
std::string formatNumber(double v);

}  // namespace ptz
