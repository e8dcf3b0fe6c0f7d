#include "common/freshness.hpp"

#include <cmath>
#include <limits>

#include "common/config.hpp"

namespace ptz {

int64_t saturatingDiffUs(int64_t later, int64_t earlier) {
  int64_t diff = 0;
  if (__builtin_sub_overflow(later, earlier, &diff)) {
    return later > earlier ? std::numeric_limits<int64_t>::max()
                           : std::numeric_limits<int64_t>::min();
  }
  return diff;
}

namespace {
Freshness judgeOne(int64_t utime, int64_t now_utime, const FreshnessLimits& limits) {
  const int64_t age_us = saturatingDiffUs(now_utime, utime);
  if (age_us < -limits.future_tolerance_us) return Freshness::kFuture;
  if (age_us > limits.max_age_us) return Freshness::kStale;
  return Freshness::kFresh;
}
}  // namespace

Freshness judgeFreshness(int64_t capture_utime, int64_t publish_utime, int64_t now_utime,
                         const FreshnessLimits& limits, bool capture_on_wall_clock) {
  const Freshness published = judgeOne(publish_utime, now_utime, limits);
  if (published != Freshness::kFresh || !capture_on_wall_clock) return published;
  return judgeOne(capture_utime, now_utime, limits);
}

bool captureOnWallClock(int64_t capture_utime, int64_t publish_utime) {
  constexpr int64_t kHourUs = 3'600'000'000;
  const int64_t lead_us = saturatingDiffUs(publish_utime, capture_utime);
  return lead_us > -kHourUs && lead_us < kHourUs;
}

double latencyMs(int64_t capture_utime, int64_t now_utime) {
  if (!captureOnWallClock(capture_utime, now_utime)) return -1;
  return saturatingDiffUs(now_utime, capture_utime) / 1000.0;
}

const char* freshnessReason(Freshness f) {
  switch (f) {
    case Freshness::kStale:
      return "stale";
    case Freshness::kFuture:
      return "future";
    default:
      return "fresh";
  }
}

void addFreshnessParams(Params& params, const std::string& name, double max_age_ms,
                        const std::string& what) {
  params.add(name + "_max_age_ms", max_age_ms, "ms",
             what + " captured or published longer ago than this is dropped (counted stale)",
             Range::above(0).andAtMost(3.6e6));
  params.add(name + "_future_tolerance_ms", 100.0, "ms",
             what + " stamped further in the future than this is dropped (counted future)",
             Range::between(0, 3.6e6));
}

FreshnessLimits freshnessFrom(const Params& params, const std::string& name) {
  // The ranges are the declaration's (checked where the values are read, naming their source).
  return {std::llround(params.getDouble(name + "_max_age_ms") * 1000),
          std::llround(params.getDouble(name + "_future_tolerance_ms") * 1000)};
}

}  // namespace ptz
