// What the benchmarks share: milliseconds of a duration, and a median/p99 line.
#pragma once

#include <chrono>
#include <cstdio>
#include <vector>

#include "common/transport/transport.hpp"

namespace ptz::bench {

using Clock = std::chrono::steady_clock;

inline double ms(Clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

inline void report(const char* what, const std::vector<double>& v) {
  std::printf("%-52s median %8.3f ms   p99 %8.3f ms   (n = %zu)\n", what, ptz::percentile(v, 50),
              ptz::percentile(v, 99), v.size());
}

// The ratio of two medians (a cost against the same run's baseline).
inline void reportRatio(const char* what, const std::vector<double>& a,
                        const std::vector<double>& b) {
  std::printf("  %-50s %.1f x\n", what, ptz::percentile(a, 50) / ptz::percentile(b, 50));
}

}  // namespace ptz::bench
