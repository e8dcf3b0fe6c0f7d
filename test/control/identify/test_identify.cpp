// ptz-identify's fit of K, T and tau to a step test of a simulated axis.
#include <gtest/gtest.h>

#include <cmath>

#include "common/plant.hpp"
#include "control/controller/delay_monitor.hpp"
#include "control/identify/identify.hpp"
#include "control/stability/stability.hpp"

using ptz::control::LoopParams;

TEST(Identify, RecoversGainTimeConstantAndDeadTimeOfASimulatedAxis) {
  // A step test of an axis with K = 0.9, T = 0.3 s, tau = 0.15 s, sampled at 100 Hz by the plant
  // model (an integrator independent of the identification's own model).
  ptz::AxisParams a;
  a.gain = 0.9;
  a.time_constant_s = 0.3;
  a.dead_time_s = 0.15;
  a.min_position = -3;
  a.max_position = 3;
  a.max_rate_per_s = 100;
  ptz::Pt1Axis axis(a, 0.0);
  ptz::control::AxisRecord record;
  for (int k = 0; k <= 300; ++k) {
    const double t = k * 0.01;
    axis.advanceTo(t, 0.0005);
    record.positions.emplace_back(t, axis.position());
    if (k % 3 == 0) {  // setpoints re-sent at ~33 Hz: 0, then a step of 0.3 at t = 0.2 s
      const double u = t < 0.2 ? 0.0 : 0.3;
      axis.command(t, u);
      record.setpoints.emplace_back(t, u);
    }
  }
  const auto fit = ptz::control::identifyAxis(record);
  ASSERT_TRUE(fit.ok) << fit.error;
  EXPECT_NEAR(fit.gain, 0.9, 0.01 * 0.9);
  EXPECT_NEAR(fit.time_constant_s, 0.3, 0.01 * 0.3);
  EXPECT_NEAR(fit.dead_time_s, 0.15, 0.01 * 0.15);

  ptz::control::AxisRecord flat = record;
  for (auto& s : flat.setpoints) s.second = 0.1;
  EXPECT_FALSE(ptz::control::identifyAxis(flat).ok);
}
