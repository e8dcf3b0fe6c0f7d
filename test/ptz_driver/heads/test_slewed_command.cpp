// ptz-driver's command of one head (SlewedCommand): the slew toward a setpoint from where the
// head is measured, and the deadman's hold, which stops the head where it is measured instead
// of slewing a command that ran ahead of the head back to it.
#include <gtest/gtest.h>

#include "common/plant.hpp"
#include "ptz_driver/heads/common/slewed_command.hpp"

using ptz::PtzPose;
using ptz::driver::SlewedCommand;

TEST(SlewedCommand, NothingIsCommandedWithoutATargetOrAMeasurement) {
  SlewedCommand c(3.0);
  EXPECT_FALSE(c.step(PtzPose{0.1, 0, 1}, 0.02));
  c.setTarget(PtzPose{1, 0, 2});
  EXPECT_FALSE(c.step(std::nullopt, 0.02)) << "the slew starts from where the head is";
}

TEST(SlewedCommand, SlewsFromWhereTheHeadIsAtMostTheRate) {
  SlewedCommand c(3.0);
  c.setTarget(PtzPose{1.0, -0.05, 2.0});
  const auto first = c.step(PtzPose{0.2, 0.0, 1.0}, 0.02);
  ASSERT_TRUE(first);
  EXPECT_DOUBLE_EQ(first->pan_rad, 0.2 + 0.06);
  EXPECT_DOUBLE_EQ(first->tilt_rad, -0.05);  // within one step
  EXPECT_DOUBLE_EQ(first->zoom, 2.0);        // zoom goes directly
  // Then from its own command, wherever the head is measured.
  const auto second = c.step(PtzPose{0.21, 0.0, 1.0}, 0.02);
  EXPECT_DOUBLE_EQ(second->pan_rad, 0.2 + 0.12);
  std::optional<PtzPose> last;
  for (int i = 0; i < 20; ++i) last = c.step(PtzPose{0.3, 0.0, 1.0}, 0.02);
  EXPECT_DOUBLE_EQ(last->pan_rad, 1.0);
}

TEST(SlewedCommand, TheHoldCommandsTheMeasuredPoseAtOnce) {
  SlewedCommand c(3.0);
  c.setTarget(PtzPose{2.5, 0.3, 4.0});
  for (int i = 0; i < 25; ++i) c.step(PtzPose{0.0, 0.0, 1.0}, 0.02);  // the command at 1.5 rad
  const PtzPose measured{0.5, 0.1, 2.5};
  ASSERT_TRUE(c.hold(measured));
  // Not 1.44 (slewing back at 3 rad/s while the head drives on toward 1.5): where it was seen.
  for (int i = 0; i < 3; ++i) {
    const auto cmd = c.step(PtzPose{0.52 + 0.01 * i, 0.11, 2.6}, 0.02);
    ASSERT_TRUE(cmd);
    EXPECT_DOUBLE_EQ(cmd->pan_rad, 0.5);
    EXPECT_DOUBLE_EQ(cmd->tilt_rad, 0.1);
    EXPECT_DOUBLE_EQ(cmd->zoom, 2.5);
  }
  // A fresh setpoint after the hold slews from the held pose.
  c.setTarget(PtzPose{0.0, 0.1, 2.5});
  EXPECT_DOUBLE_EQ(c.step(PtzPose{0.5, 0.1, 2.5}, 0.02)->pan_rad, 0.5 - 0.06);
}

TEST(SlewedCommand, AHoldWithoutAMeasurementLeavesNoTarget) {
  SlewedCommand c(3.0);
  c.setTarget(PtzPose{1, 0, 1});
  EXPECT_FALSE(c.hold(std::nullopt));
  EXPECT_FALSE(c.hasTarget());
  EXPECT_FALSE(c.step(PtzPose{0.3, 0, 1}, 0.02));
}

// A head slower than the slew (1 rad/s against 3 rad/s, a first-order lag of 0.24 s, no dead
// time), measured a tick late as through an inquiry: driven for 0.5 s, then held. It must stop
// within what it runs in a tick and a half and come to rest where it was measured.
TEST(SlewedCommand, AHeldHeadStopsWithinItsOwnRunOnAndSettles) {
  ptz::PtzPlant::Params params = ptz::defaultPlantParams();
  params.axis[ptz::PtzPlant::kPan].max_rate_per_s = 1.0;
  const PtzPose home{0, 0, 1};
  ptz::PtzPlant head(params, home, home);
  SlewedCommand c(3.0);
  const double period_s = 0.02;
  PtzPose measured = home;  // the answer to the last tick's inquiry
  double at_hold = 0, furthest = 0;
  std::optional<double> settled_after_s;
  int clamped = 0, rejected = 0;
  constexpr int kHoldTick = 38;  // the deadman, 0.25 s after the last setpoint (tick 25)
  for (int tick = 0; tick < 150; ++tick) {
    const double t = tick * period_s;
    head.advanceTo(t);
    if (tick < 25) c.setTarget(PtzPose{2.5, 0, 1});
    if (tick == kHoldTick) {
      ASSERT_TRUE(c.hold(measured));
      at_hold = measured.pan_rad;
    }
    if (const auto cmd = c.step(measured, period_s)) {
      head.command(t, *cmd, home, &clamped, &rejected);
    }
    measured = head.pose(ptz::Side::kLeft);
    if (tick < kHoldTick) continue;
    furthest = std::max(furthest, measured.pan_rad);
    if (std::abs(measured.pan_rad - at_hold) > 0.005) {
      settled_after_s.reset();
    } else if (!settled_after_s) {
      settled_after_s = t - kHoldTick * period_s;
    }
  }
  EXPECT_GT(at_hold, 0.4) << "moving at full speed when held";
  EXPECT_LE(furthest - at_hold, 1.0 * 1.5 * period_s);
  ASSERT_TRUE(settled_after_s);
  EXPECT_LE(*settled_after_s, 0.5);  // 0.02 rad to 0.005 rad: 0.24 s x ln 4 = 0.33 s
  std::printf("held at %.3f rad, ran on to %.3f, within 0.005 rad after %.2f s\n", at_hold,
              furthest, *settled_after_s);
}
