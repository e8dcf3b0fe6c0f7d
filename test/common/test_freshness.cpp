// The one freshness rule: ages from capture and publish times, overflow-safe, future refused.
#include <gtest/gtest.h>

#include <limits>

#include "common/config.hpp"
#include "common/freshness.hpp"

namespace {
constexpr int64_t kNow = 1'800'000'000'000'000;  // a wall-clock time (2027)
constexpr int64_t kMin = std::numeric_limits<int64_t>::min();
constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
const ptz::FreshnessLimits kLimits{500'000, 100'000};
}  // namespace

using ptz::Freshness;
using ptz::judgeFreshness;

TEST(Freshness, AgesFromCaptureAndPublishTime) {
  EXPECT_EQ(judgeFreshness(kNow - 499'000, kNow - 1'000, kNow, kLimits), Freshness::kFresh);
  // Published just now, but it answers a frame captured 3 s ago: stale.
  EXPECT_EQ(judgeFreshness(kNow - 3'000'000, kNow - 1'000, kNow, kLimits), Freshness::kStale);
  // A fresh frame's answer that waited in a queue for 0.6 s: stale.
  EXPECT_EQ(judgeFreshness(kNow - 601'000, kNow - 600'000, kNow, kLimits), Freshness::kStale);
  EXPECT_EQ(judgeFreshness(kNow - 501'000, kNow, kNow, kLimits), Freshness::kStale);
}

TEST(Freshness, FutureTimesBeyondTheToleranceAreRefused) {
  EXPECT_EQ(judgeFreshness(kNow + 99'000, kNow + 99'000, kNow, kLimits), Freshness::kFresh);
  EXPECT_EQ(judgeFreshness(kNow, kNow + 101'000, kNow, kLimits), Freshness::kFuture);
  EXPECT_EQ(judgeFreshness(kNow + 101'000, kNow, kNow, kLimits), Freshness::kFuture);
}

TEST(Freshness, ExtremeTimesCannotOverflowIntoFresh) {
  // now - INT64_MIN overflows a plain subtraction into a negative age ("fresh"): it saturates.
  EXPECT_EQ(judgeFreshness(kNow, kMin, kNow, kLimits), Freshness::kStale);
  EXPECT_EQ(judgeFreshness(kMin, kNow, kNow, kLimits), Freshness::kStale);
  EXPECT_EQ(judgeFreshness(kMin, kMin, kNow, kLimits), Freshness::kStale);
  EXPECT_EQ(judgeFreshness(kNow, kMax, kNow, kLimits), Freshness::kFuture);
  EXPECT_EQ(judgeFreshness(kMax, kNow, kNow, kLimits), Freshness::kFuture);
  EXPECT_EQ(judgeFreshness(kNow, kMin, kMax, kLimits), Freshness::kStale);
  EXPECT_EQ(ptz::saturatingDiffUs(kMax, -1), kMax);
  EXPECT_EQ(ptz::saturatingDiffUs(kMin, 1), kMin);
  EXPECT_EQ(ptz::saturatingDiffUs(kNow, kMin), kMax);
  EXPECT_EQ(ptz::saturatingDiffUs(5, 7), -2);
}

TEST(Freshness, SimTimeCapturesAreJudgedByThePublishTime) {
  const int64_t lockstep_capture = 1'700'000'000'000'000 + 2'000'000;
  EXPECT_FALSE(ptz::captureOnWallClock(lockstep_capture, kNow));
  EXPECT_TRUE(ptz::captureOnWallClock(kNow - 50'000, kNow));
  EXPECT_FALSE(ptz::captureOnWallClock(kMin, kNow));
  EXPECT_FALSE(ptz::captureOnWallClock(kMax, kMin));
  EXPECT_EQ(judgeFreshness(lockstep_capture, kNow - 1'000, kNow, kLimits, false),
            Freshness::kFresh);
  EXPECT_EQ(judgeFreshness(lockstep_capture, kNow - 900'000, kNow, kLimits, false),
            Freshness::kStale);
}

TEST(Freshness, LimitsComeFromParametersAndAreChecked) {
  ptz::Params p("test", "");
  ptz::addFreshnessParams(p, "setpoint", 250.0, "a setpoint");
  const ptz::FreshnessLimits l = ptz::freshnessFrom(p, "setpoint");
  EXPECT_EQ(l.max_age_us, 250'000);
  EXPECT_EQ(l.future_tolerance_us, 100'000);
  try {
    p.set("setpoint_max_age_ms", "0");
    FAIL() << "an age of 0 ms was accepted";
  } catch (const ptz::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("setpoint_max_age_ms"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("got '0'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(p.set("setpoint_future_tolerance_ms", "-1"), ptz::ConfigError);
}
