// The GPIO head's axis logic on simulated DC motors (support/hardware/gpio_rig.hpp: 4 rad/s at full
// drive, 50 ms time constant, 1000 counts/rad, switches at -1.1 and 1.1 rad, soft limits +-1 rad),
// on simulated time: homing, the position loop, limit switches, soft limits, PWM and stop.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "support/hardware/gpio_rig.hpp"

using ptz::PtzPose;
using ptz::driver::GpioAxis;
using ptz::test::emulatedAxis;
using ptz::test::GpioRig;

namespace {

constexpr double kCount = 1e-3;  // rad
constexpr int kPanDir = 0, kPanEnable = 1, kPanMin = 4, kPanMax = 5;

// A head homed and settled at 0 (pan starts 0.4 rad inside its min switch, tilt 0.2).
GpioRig homedRig() {
  const auto c = GpioRig::config();
  GpioRig rig(c, emulatedAxis(c.pan, -0.7), emulatedAxis(c.tilt, -0.9));
  rig.head->start(0);
  EXPECT_TRUE(rig.run(10, [&] {
    return rig.head->measured() && std::abs(rig.chip->positionRad(0)) < 3 * kCount &&
           std::abs(rig.chip->positionRad(1)) < 3 * kCount &&
           std::abs(rig.chip->speedRadS(0)) < 1e-3;
  }));
  return rig;
}

}  // namespace

TEST(GpioAxis, HomingSetsTheZeroAtTheSwitchThenGoesToZero) {
  const auto c = GpioRig::config();
  GpioRig rig(c, emulatedAxis(c.pan, -0.7), emulatedAxis(c.tilt, -0.9));
  EXPECT_FALSE(rig.head->measured());  // where it is is unknown until homed
  rig.head->start(0);
  ASSERT_TRUE(rig.run(5, [&] { return rig.head->measured().has_value(); }));
  // At 0.3 rad/s from -0.7 to the switch at -1.1 with the ramp's steady lag of a type-1 loop,
  // e = v (1 + K kd) / (K kp) with K = 4 rad/s per duty: (0.4 + e) / 0.3 s, detected at the
  // next control tick (2 ms).
  const double lag_rad = 0.3 * (1 + 4 * c.pan.kd_duty_s_per_rad) / (4 * c.pan.kp_duty_per_rad);
  EXPECT_NEAR(rig.t_s, (0.4 + lag_rad) / 0.3 + 0.001, 0.0015);
  // Both found their switch; the position there is the configured switch position.
  EXPECT_NEAR(rig.head->measured()->pan_rad, rig.chip->positionRad(0), 1.5 * kCount);
  EXPECT_NEAR(rig.head->measured()->tilt_rad, rig.chip->positionRad(1), 1.5 * kCount);
  EXPECT_NEAR(rig.chip->positionRad(0), -1.1, 0.01);
  EXPECT_DOUBLE_EQ(rig.head->measured()->zoom, 2.5);  // no zoom motor: the configured zoom
  // Then back to 0 at homing speed: 1.1 / 0.3 = 3.7 s.
  rig.run(4.5);
  EXPECT_NEAR(rig.chip->positionRad(0), 0, 3 * kCount);
  EXPECT_NEAR(rig.chip->positionRad(1), 0, 3 * kCount);
  EXPECT_NEAR(rig.head->measured()->pan_rad, rig.chip->positionRad(0), 1.5 * kCount);
  EXPECT_EQ(rig.head->state(0), GpioAxis::State::kReady);
  EXPECT_EQ(rig.head->stats().errors, 0);
}

TEST(GpioAxis, HomingStartingOnTheSwitchBacksOffFirst) {
  const auto c = GpioRig::config();
  GpioRig rig(c, emulatedAxis(c.pan, -1.15), emulatedAxis(c.tilt, -0.9));
  ASSERT_FALSE(rig.chip->level(kPanMin));  // closed
  rig.head->start(0);
  ASSERT_TRUE(rig.run(5, [&] { return rig.head->measured().has_value(); }));
  EXPECT_NEAR(rig.head->measured()->pan_rad, rig.chip->positionRad(0), 1.5 * kCount);
  rig.run(5);
  EXPECT_NEAR(rig.chip->positionRad(0), 0, 3 * kCount);
}

TEST(GpioAxis, HomingStartingOnTheMaxSwitchSeeksTowardMin) {
  const auto c = GpioRig::config();
  GpioRig rig(c, emulatedAxis(c.pan, 1.15), emulatedAxis(c.tilt, -0.9));
  ASSERT_FALSE(rig.chip->level(kPanMax));  // closed: the axis coasted onto it, or was pushed
  rig.head->start(0);
  // 2.25 rad to the min switch at 0.3 rad/s: 7.5 s (and the loop's lag, under 0.1 rad).
  ASSERT_TRUE(rig.run(9, [&] { return rig.head->measured().has_value(); }))
      << rig.head->stats().last_error;
  EXPECT_NEAR(rig.chip->positionRad(0), -1.1, 0.01);
  EXPECT_NEAR(rig.head->measured()->pan_rad, rig.chip->positionRad(0), 1.5 * kCount);
  rig.run(4.5);
  EXPECT_NEAR(rig.chip->positionRad(0), 0, 3 * kCount);
  EXPECT_EQ(rig.head->state(0), GpioAxis::State::kReady);
  EXPECT_EQ(rig.head->stats().errors, 0) << rig.head->stats().last_error;
}

TEST(GpioAxis, AMotorTurningTheWrongWayIsNamedWhateverTheSwitchItStartsOn) {
  const auto c = GpioRig::config();
  struct Case {
    const char* what;
    double start_rad;
    bool swap_encoder;
    double max_stop_rad;
    std::vector<std::string> said;
  };
  const Case cases[] = {
      // Leads and encoder both swapped: the counts follow the ramp while the shaft runs to max,
      // so the max switch closing (open at the start) is what tells.
      {"off the max switch", 0.9, true, 1.2, {"max limit switch closed", "swap its leads"}},
      // Leads swapped, encoder right: the counts go up while it is driven down.
      {"on the max switch", 1.15, false, 1.2, {"swap its leads", "swap its A and B"}},
      // Both swapped, no end stop: the counts go down, the max switch never opens.
      {"on the max switch, no stop", 1.15, true, 60, {"still reads closed after 2.2 rad"}},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE(k.what);
    auto pan = emulatedAxis(c.pan, k.start_rad);
    pan.reversed = true;
    if (k.swap_encoder) std::swap(pan.lines.encoder_a, pan.lines.encoder_b);
    pan.max_stop_rad = k.max_stop_rad;
    GpioRig rig(c, pan, emulatedAxis(c.tilt, -0.9));
    rig.head->start(0);
    ASSERT_TRUE(rig.run(10, [&] { return rig.head->state(0) == GpioAxis::State::kFault; }));
    const std::string said = rig.head->stats().last_error;
    for (const auto& s : k.said) EXPECT_NE(said.find(s), std::string::npos) << said;
    EXPECT_NE(said.find("left pan"), std::string::npos) << said;
    EXPECT_FALSE(rig.chip->level(kPanEnable));
  }
}

TEST(GpioAxis, AMaxSwitchStuckClosedIsNamedWhenTheMinSwitchCloses) {
  const auto c = GpioRig::config();
  auto pan = emulatedAxis(c.pan, 0);
  pan.max_switch_rad = -10;  // reads closed everywhere (a shorted wire)
  GpioRig rig(c, pan, emulatedAxis(c.tilt, -0.9));
  rig.head->start(0);
  ASSERT_TRUE(rig.run(6, [&] { return rig.head->state(0) == GpioAxis::State::kFault; }));
  EXPECT_NE(rig.head->stats().last_error.find("both limit switches read closed"), std::string::npos)
      << rig.head->stats().last_error;
  EXPECT_NEAR(rig.chip->positionRad(0), -1.1, 0.02);  // it went down to the min switch
}

TEST(GpioAxis, HomingTimeoutIsAnErrorNamingTheAxis) {
  auto c = GpioRig::config();
  c.pan.homing_timeout_s = 2;
  auto pan = emulatedAxis(c.pan, 0);
  pan.min_switch_rad = -50;  // never reached in 2 s
  pan.min_stop_rad = -60;
  GpioRig rig(c, pan, emulatedAxis(c.tilt, -0.9));
  rig.head->start(0);
  rig.run(2.5);
  EXPECT_EQ(rig.head->state(0), GpioAxis::State::kFault);
  EXPECT_FALSE(rig.head->measured());
  const auto& s = rig.head->stats();
  EXPECT_EQ(s.errors, 1);
  EXPECT_NE(s.last_error.find("left pan: homing timed out"), std::string::npos) << s.last_error;
  EXPECT_NE(s.last_error.find("line 4"), std::string::npos) << s.last_error;
  EXPECT_FALSE(rig.chip->level(kPanEnable));
  const double at_rad = rig.chip->positionRad(0);
  rig.run(1);                                                          // and it stays stopped
  EXPECT_NEAR(rig.chip->positionRad(0), at_rad, 0.3 * 0.05 + kCount);  // coasts, no drive
}

TEST(GpioAxis, AStopDuringHomingInterruptsItAndSaysSo) {
  const auto c = GpioRig::config();
  GpioRig rig(c, emulatedAxis(c.pan, -0.7), emulatedAxis(c.tilt, -0.9));
  rig.head->start(0);
  rig.run(0.5);
  rig.head->stop(rig.t_s, 0.1);
  EXPECT_FALSE(rig.chip->level(kPanEnable));
  rig.run(1);
  EXPECT_EQ(rig.head->state(0), GpioAxis::State::kIdle);
  EXPECT_FALSE(rig.head->measured());
  rig.head->command(PtzPose{0.5, 0.5, 1}, rig.t_s);  // not homed: not moved
  rig.run(0.5);
  EXPECT_FALSE(rig.chip->level(kPanEnable));
  EXPECT_EQ(rig.head->stats().errors, 2);  // both axes
  EXPECT_NE(rig.head->stats().last_error.find("homing interrupted"), std::string::npos);
}

TEST(GpioAxis, AnEncoderCountingTheWrongWayFailsHoming) {
  auto c = GpioRig::config();
  auto pan = emulatedAxis(c.pan, -0.5);
  std::swap(pan.lines.encoder_a, pan.lines.encoder_b);  // A and B wired the other way round
  GpioRig rig(c, pan, emulatedAxis(c.tilt, -0.9));
  rig.head->start(0);
  rig.run(3);
  EXPECT_EQ(rig.head->state(0), GpioAxis::State::kFault);
  EXPECT_NE(rig.head->stats().last_error.find("swap its A and B"), std::string::npos);
  // It never reached the switch: the lag check stopped it first.
  EXPECT_GT(rig.chip->minPositionRad(0), -1.1);
}

TEST(GpioAxis, PositionLoopReachesTheTargetWithinThreeCounts) {
  GpioRig rig = homedRig();
  rig.head->command(PtzPose{0.5, -0.3, 1}, rig.t_s);
  const double t0 = rig.t_s;
  // 0.5 rad at up to 3.2 rad/s (duty 0.8), then braking: within 3 counts in 0.4 s (0.36 s).
  ASSERT_TRUE(rig.run(2, [&] {
    return std::abs(rig.chip->positionRad(0) - 0.5) <= 3 * kCount &&
           std::abs(rig.chip->positionRad(1) + 0.3) <= 3 * kCount;
  }));
  std::printf("0.5 rad step: within 3 counts after %.3f s\n", rig.t_s - t0);
  EXPECT_LT(rig.t_s - t0, 0.4);
  rig.run(0.5);  // and stays
  EXPECT_NEAR(rig.chip->positionRad(0), 0.5, 3 * kCount);
  EXPECT_NEAR(rig.chip->positionRad(1), -0.3, 3 * kCount);
  EXPECT_NEAR(rig.head->measured()->pan_rad, rig.chip->positionRad(0), 1.5 * kCount);
  EXPECT_EQ(rig.head->stats().malformed, 0);
}

TEST(GpioAxis, ALimitSwitchStopsMotionTowardItAndAllowsMotionAway) {
  GpioRig rig = homedRig();
  rig.chip->setSwitch(0, false, -0.5);  // an obstacle closes the min switch early
  bool drove_into_switch = false;
  auto watch = [&] {
    const bool on = rig.chip->level(kPanEnable), up = rig.chip->level(kPanDir);
    if (on && ((!up && !rig.chip->level(kPanMin)) || (up && !rig.chip->level(kPanMax))))
      drove_into_switch = true;
  };
  double min_rad = 0, max_rad = 0;
  auto watch_and_track = [&] {
    watch();
    min_rad = std::min(min_rad, rig.chip->positionRad(0));
    max_rad = std::max(max_rad, rig.chip->positionRad(0));
  };
  rig.head->command(PtzPose{-0.8, 0, 1}, rig.t_s);
  rig.run(1.5, {}, watch_and_track);
  EXPECT_FALSE(drove_into_switch);
  // It coasts past the switch (at most speed x time constant = 3.2 * 0.05) and stays.
  EXPECT_LE(rig.chip->positionRad(0), -0.5);
  EXPECT_GT(min_rad, -0.5 - 0.16);
  // Away from it: allowed.
  rig.head->command(PtzPose{0.3, 0, 1}, rig.t_s);
  rig.run(1, {}, watch);
  EXPECT_NEAR(rig.chip->positionRad(0), 0.3, 3 * kCount);
  // The max end likewise.
  rig.chip->setSwitch(0, true, 0.6);
  rig.head->command(PtzPose{0.9, 0, 1}, rig.t_s);
  rig.run(1.5, {}, watch_and_track);
  EXPECT_FALSE(drove_into_switch);
  EXPECT_GE(rig.chip->positionRad(0), 0.6);
  EXPECT_LT(max_rad, 0.6 + 0.16);
  rig.head->command(PtzPose{0, 0, 1}, rig.t_s);
  rig.run(1, {}, watch);
  EXPECT_NEAR(rig.chip->positionRad(0), 0, 3 * kCount);
}

TEST(GpioAxis, ASetpointBeyondTheSoftLimitNeverDrivesPastIt) {
  GpioRig rig = homedRig();
  bool drove_out = false;
  auto watch = [&] {
    if (rig.chip->level(kPanEnable) && rig.chip->level(kPanDir) &&
        rig.head->measured()->pan_rad >= 1.0)
      drove_out = true;
  };
  rig.head->command(PtzPose{5.0, 0, 1}, rig.t_s);  // soft max is 1 rad, the switch 1.1
  rig.run(2, {}, watch);
  EXPECT_FALSE(drove_out);
  EXPECT_LE(rig.chip->maxPositionRad(0), 1.0 + 3 * kCount);
  EXPECT_NEAR(rig.chip->positionRad(0), 1.0, 3 * kCount);
  EXPECT_TRUE(rig.chip->level(kPanMax));  // the switch was never reached
}

TEST(GpioAxis, PwmRunsAtPwmHzWithTheDutyLimited) {
  GpioRig rig = homedRig();
  rig.head->command(PtzPose{0.9, 0, 1}, rig.t_s);
  rig.run(0.01);  // the next control tick takes the command
  const double high0_s = rig.chip->highTimeS(kPanEnable);
  const int64_t rises0 = rig.chip->risingEdges(kPanEnable);
  rig.run(0.1);  // 0.9 rad of error: saturated at max_duty 0.8 all along
  EXPECT_NEAR(rig.chip->risingEdges(kPanEnable) - rises0, 100, 1);  // 1 kHz
  // 0.8 ms of every 1 ms period (the window's ends cut at most one period's 0.8 ms).
  EXPECT_NEAR(rig.chip->highTimeS(kPanEnable) - high0_s, 0.08, 0.8e-3 + 1e-9);
}

TEST(GpioAxis, StopLeavesTheEnableLineLowAndTheHeadHolds) {
  GpioRig rig = homedRig();
  rig.head->command(PtzPose{0.8, 0.5, 1}, rig.t_s);
  rig.run(0.1);
  ASSERT_GT(rig.chip->speedRadS(0), 1.0);  // moving
  rig.head->stop(rig.t_s, 0.1);
  EXPECT_FALSE(rig.chip->level(kPanEnable));  // at once, before any step
  EXPECT_FALSE(rig.chip->level(kPanDir));
  const double high_s = rig.chip->highTimeS(kPanEnable);
  rig.run(0.5);
  const double rest_rad = rig.chip->positionRad(0);
  rig.run(1.0);
  EXPECT_DOUBLE_EQ(rig.chip->highTimeS(kPanEnable), high_s);  // never driven again
  EXPECT_FALSE(rig.chip->level(kPanDir));
  EXPECT_NEAR(rig.chip->positionRad(0), rest_rad, kCount);
  EXPECT_EQ(rig.head->state(0), GpioAxis::State::kStopped);
  EXPECT_NEAR(rig.head->measured()->pan_rad, rig.chip->positionRad(0), 1.5 * kCount);
  // A new command moves it again.
  rig.head->command(PtzPose{0.8, 0.5, 1}, rig.t_s);
  rig.run(1.0);
  EXPECT_NEAR(rig.chip->positionRad(0), 0.8, 3 * kCount);
}

TEST(GpioAxis, IllegalEncoderTransitionsAreReportedAsMalformed) {
  GpioRig rig = homedRig();
  constexpr int kPanA = 2;
  rig.chip->injectEvent(kPanA, rig.chip->level(kPanA));
  rig.run(0.01);
  EXPECT_EQ(rig.head->stats().malformed, 1);
}
