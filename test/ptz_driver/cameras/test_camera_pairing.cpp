// Stereo pairing by capture time with known timestamp sequences: a delayed stream within and
// beyond the tolerance, frames dropped on either side, bounded buffers, and what a rig that never
// pairs is told.
#include <gtest/gtest.h>

#include <set>
#include <utility>
#include <vector>

#include "ptz_driver/cameras/stereo_pairer.hpp"

using ptz::Side;
using ptz::driver::CapturedFrame;
using ptz::driver::PairerParams;
using ptz::driver::StereoPairer;

namespace {

constexpr int64_t kPeriodUs = 40'000;  // 25 Hz

CapturedFrame frame(int64_t capture_utime, int64_t index) {
  CapturedFrame f;
  f.capture_utime = capture_utime;
  f.index = index;
  return f;
}

struct Outcome {
  std::vector<std::pair<int64_t, int64_t>> pairs;  // (left index, right index)
  int64_t unmatched_left = 0, unmatched_right = 0;
};

// n frames a side, left at k * period, right at k * period + delay; the dropped indices are not
// delivered. Frames arrive in capture-time order (arrival = capture time), then both sides end.
Outcome play(int n, int64_t delay_us, int64_t tolerance_us, const std::set<int>& drop_left,
             const std::set<int>& drop_right) {
  StereoPairer p(PairerParams{tolerance_us, 30, 2.0});
  std::vector<std::pair<int64_t, std::pair<Side, int>>> arrivals;
  for (int k = 0; k < n; ++k) {
    if (!drop_left.count(k)) arrivals.push_back({k * kPeriodUs, {Side::kLeft, k}});
    if (!drop_right.count(k)) arrivals.push_back({k * kPeriodUs + delay_us, {Side::kRight, k}});
  }
  std::stable_sort(arrivals.begin(), arrivals.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  Outcome run;
  for (const auto& [t, who] : arrivals) {
    p.add(who.first, frame(t, who.second), t);
    for (const auto& pair : p.takePairs()) run.pairs.push_back({pair.left.index, pair.right.index});
  }
  p.setEnded(Side::kLeft);
  p.setEnded(Side::kRight);
  for (const auto& pair : p.takePairs()) run.pairs.push_back({pair.left.index, pair.right.index});
  run.unmatched_left = p.unmatched(Side::kLeft);
  run.unmatched_right = p.unmatched(Side::kRight);
  EXPECT_EQ(p.pairs(), static_cast<int64_t>(run.pairs.size()));
  return run;
}

std::vector<std::pair<int64_t, int64_t>> sameIndex(int n, const std::set<int>& missing) {
  std::vector<std::pair<int64_t, int64_t>> v;
  for (int k = 0; k < n; ++k) {
    if (!missing.count(k)) v.push_back({k, k});
  }
  return v;
}

}  // namespace

TEST(CameraPairing, ARightStreamDelayedWithinTheTolerancePairsFrameForFrame) {
  const Outcome late = play(50, 8'000, 12'000, {}, {});
  EXPECT_EQ(late.pairs, sameIndex(50, {}));
  EXPECT_EQ(late.unmatched_left, 0);
  EXPECT_EQ(late.unmatched_right, 0);
  const Outcome early = play(50, -11'000, 12'000, {}, {});  // right ahead
  EXPECT_EQ(early.pairs, sameIndex(50, {}));
}

TEST(CameraPairing, ADelayBeyondTheToleranceMakesNoPairs) {
  const Outcome r = play(50, 18'000, 12'000, {}, {});
  EXPECT_TRUE(r.pairs.empty());
  EXPECT_EQ(r.unmatched_left, 50);
  EXPECT_EQ(r.unmatched_right, 50);
}

TEST(CameraPairing, DroppedFramesLeaveTheirPartnersUnmatchedAndNothingElse) {
  const Outcome r = play(50, 8'000, 12'000, {33}, {7, 20, 21});
  EXPECT_EQ(r.pairs, sameIndex(50, {7, 20, 21, 33}));
  EXPECT_EQ(r.unmatched_left, 3);   // 7, 20, 21
  EXPECT_EQ(r.unmatched_right, 1);  // 33
  // The same drops on the same instant on both sides: nothing unmatched.
  const Outcome both = play(50, 8'000, 12'000, {5}, {5});
  EXPECT_EQ(both.pairs, sameIndex(50, {5}));
  EXPECT_EQ(both.unmatched_left + both.unmatched_right, 0);
}

TEST(CameraPairing, ASideThatArrivesLateStillPairsByCaptureTime) {
  // All right frames arrive after all left ones (a slow link): the buffer holds the left ones.
  StereoPairer p(PairerParams{12'000, 30, 2.0});
  for (int k = 0; k < 20; ++k) p.add(Side::kLeft, frame(k * kPeriodUs, k), k * kPeriodUs);
  EXPECT_TRUE(p.takePairs().empty());
  for (int k = 0; k < 20; ++k) p.add(Side::kRight, frame(k * kPeriodUs + 5'000, k), 1'000'000);
  const auto pairs = p.takePairs();
  ASSERT_EQ(pairs.size(), 20u);
  for (int k = 0; k < 20; ++k) EXPECT_EQ(pairs[k].right.index, pairs[k].left.index);
  EXPECT_EQ(pairs[3].first_arrival_utime, 3 * kPeriodUs);
}

TEST(CameraPairing, BuffersAreBoundedAndTheOverflowIsUnmatched) {
  StereoPairer p(PairerParams{12'000, 10, 2.0});
  for (int k = 0; k < 40; ++k) p.add(Side::kLeft, frame(k * kPeriodUs, k), k * kPeriodUs);
  EXPECT_EQ(p.waiting(Side::kLeft), 10u);
  EXPECT_EQ(p.unmatched(Side::kLeft), 30);
  p.setEnded(Side::kRight);
  EXPECT_EQ(p.waiting(Side::kLeft), 0u);
  EXPECT_EQ(p.unmatched(Side::kLeft), 40);
}

TEST(CameraPairing, AFrameOutOfOrderIsUnmatchedAtOnce) {
  StereoPairer p(PairerParams{12'000, 30, 2.0});
  p.add(Side::kLeft, frame(100'000, 0), 0);
  p.add(Side::kLeft, frame(100'000, 1), 0);  // the same time again
  p.add(Side::kLeft, frame(50'000, 2), 0);   // earlier
  EXPECT_EQ(p.unmatched(Side::kLeft), 2);
  p.add(Side::kRight, frame(104'000, 0), 0);
  ASSERT_EQ(p.takePairs().size(), 1u);
}

TEST(CameraPairing, ARigThatNeverPairsSaysHowFarApartTheSidesAreAfterTheWarningTime) {
  StereoPairer p(PairerParams{12'000, 30, 2.0});
  const int64_t start = 1'700'000'000'000'000;
  int64_t now = start;
  for (int k = 0; k < 60; ++k) {  // 2.4 s, right 18 ms after left
    now = start + k * kPeriodUs;
    p.add(Side::kLeft, frame(now, k), now);
    p.add(Side::kRight, frame(now + 18'000, k), now + 18'000);
    if (now + 18'000 - start < 2'000'000) {
      EXPECT_EQ(p.noPairMessage(now + 18'000), "") << k;
    }
  }
  ASSERT_TRUE(p.typicalOffsetS());
  EXPECT_NEAR(*p.typicalOffsetS(), 0.018, 1e-9);
  EXPECT_EQ(p.noPairMessage(start + 18'000 + 2'000'000),  // both sides deliver since +18 ms
            "no stereo pair in 2.0 s: right is 0.018 s behind left (tolerance 0.012 s); check "
            "the clocks or raise pair_tolerance_s");
  // Only one side delivering is another problem (the source's), not this one.
  EXPECT_EQ(p.noPairMessage(now + 2'100'000), "");
  // Right ahead of left.
  StereoPairer q(PairerParams{12'000, 30, 1.0});
  for (int k = 0; k < 30; ++k) {
    q.add(Side::kRight, frame(start + k * kPeriodUs, k), start + k * kPeriodUs);
    q.add(Side::kLeft, frame(start + k * kPeriodUs + 15'000, k), start + k * kPeriodUs + 15'000);
  }
  EXPECT_EQ(q.noPairMessage(start + 29 * kPeriodUs + 15'000),
            "no stereo pair in 1.2 s: right is 0.015 s ahead of left (tolerance 0.012 s); check "
            "the clocks or raise pair_tolerance_s");
}

TEST(CameraPairing, AfterAPairTheWarningWaitsAWholeWarningTimeAgain) {
  StereoPairer p(PairerParams{12'000, 30, 1.0});
  const int64_t start = 1'000'000'000;
  p.add(Side::kLeft, frame(start, 0), start);
  p.add(Side::kRight, frame(start + 1'000, 0), start + 1'000);  // a pair at start + 1 ms
  ASSERT_EQ(p.takePairs().size(), 1u);
  for (int k = 1; k < 40; ++k) {
    const int64_t t = start + k * kPeriodUs;
    p.add(Side::kLeft, frame(t, k), t);
    p.add(Side::kRight, frame(t + 20'000, k), t + 20'000);
  }
  EXPECT_EQ(p.noPairMessage(start + 1'000 + 999'999), "");
  EXPECT_NE(p.noPairMessage(start + 1'000 + 1'000'000), "");
}
