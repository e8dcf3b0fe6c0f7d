// The one freshness rule for commands and inputs (DESIGN "Robustness rules"): a message is stale
// when the frame it answers was captured too long ago or it was published too long ago, and
// refused when either time lies in the future beyond a tolerance. The arithmetic saturates, so no
// time a sender can put in a message overflows it.
#pragma once

#include <cstdint>
#include <string>

namespace ptz {

class Params;

struct FreshnessLimits {
  int64_t max_age_us = 500'000;
  int64_t future_tolerance_us = 100'000;
};

enum class Freshness { kFresh, kStale, kFuture };

// later - earlier, saturated to the int64 range.
int64_t saturatingDiffUs(int64_t later, int64_t earlier);

// Judges a message by its publish time (wall clock) and, when capture_on_wall_clock, by the capture
// time of the frame it answers. A lockstep simulator stamps capture times in sim time: those are
// judged by the publish time alone.
Freshness judgeFreshness(int64_t capture_utime, int64_t publish_utime, int64_t now_utime,
                         const FreshnessLimits& limits, bool capture_on_wall_clock = true);

// Whether capture and publish times are on one clock: a lockstep run's capture times are sim time
// (years before its wall-clock publish times); a real capture precedes its publication by far less
// than an hour.
bool captureOnWallClock(int64_t capture_utime, int64_t publish_utime);

// Latency from a message's capture time to now_utime, ms, for the statuses; -1 (unknown) when the
// capture time is not on the wall clock (sim time, or a hostile value).
double latencyMs(int64_t capture_utime, int64_t now_utime);

// "stale" or "future": the drop reason counted in the status.
const char* freshnessReason(Freshness f);

// Declares NAME_max_age_ms (0 < age <= 1 h) and NAME_future_tolerance_ms (0 .. 1 h), e.g. for
// setpoint, frame, pose.
void addFreshnessParams(Params& params, const std::string& name, double max_age_ms,
                        const std::string& what);
// Reads them back.
FreshnessLimits freshnessFrom(const Params& params, const std::string& name);

}  // namespace ptz
