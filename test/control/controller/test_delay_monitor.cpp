// ptz-control's live delay monitor: the delay distribution and the phase margin it leaves.
#include <gtest/gtest.h>

#include <cmath>

#include "common/plant.hpp"
#include "control/controller/delay_monitor.hpp"
#include "control/identify/identify.hpp"
#include "control/stability/stability.hpp"

using ptz::control::LoopParams;

TEST(DelayMonitor, ReportsTheDelayAndTheMarginItLeaves) {
  ptz::control::DelayMonitor monitor({1.7, 0.24, 0.0}, 0.05, 60.0);
  for (int i = 1; i <= 100; ++i) monitor.add(i * 0.001);  // 1..100 ms measured
  monitor.add(-1.0);                                      // ignored: negative
  monitor.add(1.0e8);                                     // ignored: lockstep's sim time
  EXPECT_EQ(monitor.samples(), 100u);
  const auto r = monitor.report();
  EXPECT_NEAR(r.delay_ms_p50, 50 + 50, 1e-9);  // plus the plant's 50 ms dead time
  EXPECT_NEAR(r.delay_ms_p99, 99 + 50, 1e-9);
  // 126.03 deg - 5.728 rad/s * 0.149 s = 77.1 deg.
  const double expected = 180 - std::atan(std::sqrt(1.7 * 1.7 - 1)) * 180 / M_PI -
                          std::sqrt(1.7 * 1.7 - 1) / 0.24 * 0.149 * 180 / M_PI;
  EXPECT_NEAR(r.phase_margin_deg, expected, 1e-9);
  EXPECT_FALSE(r.below_threshold);
  for (int i = 0; i < 10; ++i) monitor.add(0.3);  // 350 ms in all: little margin left
  const auto late = monitor.report();
  EXPECT_LT(late.phase_margin_deg, 60.0);
  EXPECT_TRUE(late.below_threshold);
  EXPECT_EQ(monitor.samples(), 0u);
}
