// Pan/tilt/zoom at an image's capture time from the PTZ_STATE history: linear interpolation with
// known answers, the nearest state outside the history, stale beyond the extrapolation limit.
#include <gtest/gtest.h>

#include "ptz_driver/cameras/ptz_history.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::driver::PtzHistory;

TEST(CameraPtz, PosesAreInterpolatedLinearlyBetweenTheStatesAroundTheCaptureTime) {
  PtzHistory h(2.0, 0.1);
  ASSERT_TRUE(h.add(1'000'000, {0.1, -0.2, 1.0}, {-0.5, 0.0, 2.0}));
  ASSERT_TRUE(h.add(1'020'000, {0.3, 0.2, 3.0}, {-0.3, 0.4, 2.0}));
  ASSERT_TRUE(h.add(1'040'000, {0.3, 0.2, 3.0}, {0.5, 0.4, 1.0}));
  auto l = h.at(Side::kLeft, 1'005'000);  // a quarter of the way
  EXPECT_FALSE(l.stale);
  EXPECT_DOUBLE_EQ(l.pose.pan_rad, 0.15);
  EXPECT_DOUBLE_EQ(l.pose.tilt_rad, -0.1);
  EXPECT_DOUBLE_EQ(l.pose.zoom, 1.5);
  auto r = h.at(Side::kRight, 1'030'000);  // half way between the second and third state
  EXPECT_DOUBLE_EQ(r.pose.pan_rad, 0.1);
  EXPECT_DOUBLE_EQ(r.pose.tilt_rad, 0.4);
  EXPECT_DOUBLE_EQ(r.pose.zoom, 1.5);
  // At a state's own time: that state.
  EXPECT_DOUBLE_EQ(h.at(Side::kLeft, 1'020'000).pose.pan_rad, 0.3);
  EXPECT_DOUBLE_EQ(h.at(Side::kRight, 1'040'000).pose.pan_rad, 0.5);
}

TEST(CameraPtz, OutsideTheHistoryTheNearestStateIsUsedAndBeyondTheLimitItIsStale) {
  PtzHistory h(2.0, 0.1);
  h.add(1'000'000, {0.1, 0.0, 1.0}, {0.2, 0.0, 1.0});
  h.add(1'020'000, {0.3, 0.0, 1.0}, {0.4, 0.0, 1.0});
  auto before = h.at(Side::kLeft, 900'000);  // 0.1 s before: not stale yet
  EXPECT_FALSE(before.stale);
  EXPECT_DOUBLE_EQ(before.pose.pan_rad, 0.1);
  EXPECT_TRUE(h.at(Side::kLeft, 899'999).stale);
  auto after = h.at(Side::kRight, 1'120'000);
  EXPECT_FALSE(after.stale);
  EXPECT_DOUBLE_EQ(after.pose.pan_rad, 0.4);
  auto late = h.at(Side::kRight, 1'120'001);
  EXPECT_TRUE(late.stale);
  EXPECT_DOUBLE_EQ(late.pose.pan_rad, 0.4);
}

TEST(CameraPtz, WithoutAnyStateFramesGetTheHomePoseAndAreStale) {
  PtzHistory h(2.0, 0.1);
  const auto s = h.at(Side::kLeft, 123);
  EXPECT_TRUE(s.stale);
  EXPECT_EQ(s.pose.pan_rad, 0.0);
  EXPECT_EQ(s.pose.tilt_rad, 0.0);
  EXPECT_EQ(s.pose.zoom, 1.0);
}

TEST(CameraPtz, StatesNotNewerAreRefusedAndOldOnesForgotten) {
  PtzHistory h(1.0, 0.1);
  EXPECT_TRUE(h.add(5'000'000, {}, {}));
  EXPECT_FALSE(h.add(5'000'000, {}, {}));
  EXPECT_FALSE(h.add(4'000'000, {}, {}));
  for (int k = 1; k <= 100; ++k) h.add(5'000'000 + k * 20'000, {k * 0.01, 0, 1}, {});
  // 1 s of history at 50 Hz: the states from 6.0 s back to 5.0 s... and no older.
  EXPECT_EQ(h.size(), 51u);
  EXPECT_TRUE(h.at(Side::kLeft, 5'000'000 + 20'000 * 50 - 100'001).stale);
  EXPECT_NEAR(h.at(Side::kLeft, 5'000'000 + 20'000 * 75 + 10'000).pose.pan_rad, 0.755, 1e-12);
}

TEST(CameraPtz, TimeGoingBackMoreThanTheHistoryStartsTheHistoryAgain) {
  PtzHistory h(1.0, 0.1);
  for (int k = 0; k <= 50; ++k) ASSERT_TRUE(h.add(100'000'000 + k * 20'000, {0.5, 0, 1}, {}));
  // A late state within the history is still refused, and so is one exactly history_s older.
  EXPECT_FALSE(h.add(100'990'000, {}, {}));
  EXPECT_FALSE(h.add(100'000'000, {}, {}));
  EXPECT_EQ(h.restarts(), 0);
  // A looped log: time starts again 100 s earlier. The new time line is taken, counted once.
  EXPECT_TRUE(h.add(1'000'000, {0.1, 0, 1}, {}));
  EXPECT_EQ(h.restarts(), 1);
  EXPECT_EQ(h.size(), 1u);
  EXPECT_TRUE(h.add(1'020'000, {0.3, 0, 1}, {}));
  EXPECT_EQ(h.newestUtime(), 1'020'000);
  EXPECT_EQ(h.restarts(), 1);
  const auto l = h.at(Side::kLeft, 1'010'000);
  EXPECT_FALSE(l.stale);
  EXPECT_DOUBLE_EQ(l.pose.pan_rad, 0.2);
}
