// ptz-identify's step test from the messages: the axis by name, the clocks, the report.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "control/identify/step_test.hpp"

namespace pc = ptz::control;

TEST(StepTest, AxisNamesAreTheSixAxes) {
  const auto a = pc::parseAxisName("right_tilt");
  ASSERT_TRUE(a);
  EXPECT_FALSE(a->left);
  EXPECT_EQ(a->what, "tilt");
  EXPECT_TRUE(pc::parseAxisName("left_zoom")->left);
  EXPECT_FALSE(pc::parseAxisName("left"));
  EXPECT_FALSE(pc::parseAxisName("up_pan"));
  EXPECT_FALSE(pc::parseAxisName("left_roll"));
}

namespace {

ptzstereo::ptz_state_t state(int64_t utime, int64_t publish_utime, double right_tilt_rad) {
  ptzstereo::ptz_state_t s{};
  s.utime = utime;
  s.publish_utime = publish_utime;
  s.right.tilt_rad = right_tilt_rad;
  s.left.tilt_rad = -1;  // not the axis asked for
  return s;
}

ptzstereo::ptz_setpoint_t setpoint(int64_t utime, int64_t publish_utime, double right_tilt_rad) {
  ptzstereo::ptz_setpoint_t s{};
  s.utime = utime;
  s.publish_utime = publish_utime;
  s.right.tilt_rad = right_tilt_rad;
  return s;
}

}  // namespace

TEST(StepTest, SetpointsActFromThePublishTimeInRealTimeAndFromTheFrameTimeInLockstep) {
  const auto axis = *pc::parseAxisName("right_tilt");
  const int64_t wall = 1'750'000'000'000'000;
  const pc::StepTest realtime =
      pc::stepTestOf({state(wall, wall + 1'000, 0.0), state(wall + 10'000, wall + 11'000, 0.1)},
                     {setpoint(wall - 5'000, wall + 2'000, 0.3)}, axis);
  EXPECT_FALSE(realtime.lockstep);
  ASSERT_EQ(realtime.record.positions.size(), 2u);
  EXPECT_DOUBLE_EQ(realtime.record.positions[1].first, (wall + 10'000) * 1e-6);
  EXPECT_DOUBLE_EQ(realtime.record.positions[1].second, 0.1);
  ASSERT_EQ(realtime.record.setpoints.size(), 1u);
  EXPECT_DOUBLE_EQ(realtime.record.setpoints[0].first, (wall + 2'000) * 1e-6);
  EXPECT_DOUBLE_EQ(realtime.record.setpoints[0].second, 0.3);

  const int64_t sim = 1'700'000'000'000'000;  // a lockstep run's sim time, years before
  const pc::StepTest lockstep =
      pc::stepTestOf({state(sim, wall, 0.0)}, {setpoint(sim + 33'000, wall + 500, 0.3)}, axis);
  EXPECT_TRUE(lockstep.lockstep);
  EXPECT_DOUBLE_EQ(lockstep.record.setpoints[0].first, (sim + 33'000) * 1e-6);
}

TEST(StepTest, TheReportGivesTheFitAndThePapersMarginsWithIt) {
  pc::StepTest test;
  test.record.positions = {{0, 0}, {0.01, 0}};
  test.record.setpoints = {{0, 0}};
  pc::AxisFit fit;
  fit.ok = true;
  fit.gain = 1.0;
  fit.time_constant_s = 0.24;
  const std::string text = pc::fitReport("right_tilt", test, fit, 1.7);
  EXPECT_EQ(text.substr(0, text.find('\n') + 1),
            "right_tilt from 2 states and 1 setpoints (real-time clock):\n");
  EXPECT_NE(text.find("  K = 1.0000   T = 0.2400 s   tau = 0.0000 s"), std::string::npos);
  EXPECT_NE(text.find("omega_g = 5.728 rad/s, phase margin 126.0 deg"), std::string::npos);
  EXPECT_NE(text.find("tau_max = 0.384 s\n"), std::string::npos);
  fit.gain = 0.5;  // 1.7 * 0.5 < 1
  EXPECT_NE(pc::fitReport("right_tilt", test, fit, 1.7).find("stable for any delay"),
            std::string::npos);
}
