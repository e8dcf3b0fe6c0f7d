// The PT1 + dead-time motor model against its analytic step response, and its limits.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "common/config.hpp"
#include "common/plant.hpp"

using ptz::AxisParams;
using ptz::Pt1Axis;

namespace {
AxisParams paperAxis(double tau) {
  AxisParams p;
  p.gain = 1.7;  // any K: the response is K * step * (1 - exp(-t/T)) after the dead time
  p.time_constant_s = 0.24;
  p.dead_time_s = tau;
  p.min_position = -10;
  p.max_position = 10;
  p.max_rate_per_s = 1000;
  return p;
}
}  // namespace

TEST(Plant, StepResponseIsThePt1Solution) {
  const double tau = 0.1, step = 0.5, dt = 0.0005;
  Pt1Axis axis(paperAxis(tau), 0.0);
  axis.command(0.0, step);
  // 63.2 % of K * step one time constant after the dead time.
  axis.advanceTo(tau + 0.24, dt);
  EXPECT_NEAR(axis.position(), 1.7 * step * (1 - std::exp(-1.0)), 1e-9);
  EXPECT_NEAR(axis.position() / (1.7 * step), 0.632, 0.001);
  for (double t : {0.3, 0.5, 1.0, 2.0}) {
    axis.advanceTo(tau + t, dt);
    EXPECT_NEAR(axis.position(), 1.7 * step * (1 - std::exp(-t / 0.24)), 1e-9) << t;
  }
}

TEST(Plant, DeadTimeIsExactToWithinOneStep) {
  const double tau = 0.0734, dt = 0.0005;
  Pt1Axis axis(paperAxis(tau), 0.0);
  axis.command(0.0, 1.0);
  axis.advanceTo(tau, dt);
  EXPECT_EQ(axis.position(), 0.0);  // nothing moves before tau
  axis.advanceTo(tau + dt, dt);
  EXPECT_GT(axis.position(), 0.0);  // and it moves within one step after
  EXPECT_NEAR(axis.position(), 1.7 * (1 - std::exp(-dt / 0.24)), 1e-12);
}

TEST(Plant, LaterSetpointsReplaceEarlierOnesAfterTheDeadTime) {
  Pt1Axis axis(paperAxis(0.05), 0.0);
  axis.command(0.0, 1.0);
  axis.command(0.02, -1.0);  // takes effect at 0.07
  axis.advanceTo(0.07, 0.001);
  const double at_switch = axis.position();
  EXPECT_NEAR(at_switch, 1.7 * (1 - std::exp(-0.02 / 0.24)), 1e-9);
  axis.advanceTo(0.07 + 0.24, 0.001);
  // From at_switch towards -1.7 with the same time constant.
  EXPECT_NEAR(axis.position(), -1.7 + (at_switch + 1.7) * std::exp(-1.0), 1e-9);
}

TEST(Plant, RateLimitHolds) {
  AxisParams p = paperAxis(0);
  p.gain = 1;
  p.max_rate_per_s = 0.5;
  Pt1Axis axis(p, 0.0);
  axis.command(0, 5.0);
  axis.advanceTo(1.0, 0.001);
  EXPECT_NEAR(axis.position(), 0.5, 1e-9);  // saturated at 0.5/s for the whole second
}

TEST(Plant, LimitsHoldUnderAnySetpointSequence) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> wide(-1e6, 1e6), near(-4, 4), dt(0.0, 0.05);
  std::uniform_int_distribution<int> kind(0, 5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  AxisParams p;
  p.gain = 1.3;  // a gain above one must not push the axis past its limits either
  p.time_constant_s = 0.05;
  p.dead_time_s = 0.03;
  p.min_position = -2.9;
  p.max_position = 2.9;
  p.max_rate_per_s = 5.0;
  Pt1Axis axis(p, 0.0);
  double t = 0;
  int rejected = 0, clamped = 0;
  for (int i = 0; i < 20000; ++i) {
    double value = 0;
    switch (kind(rng)) {
      case 0:
        value = nan;
        break;
      case 1:
        value = (i % 2 ? inf : -inf);
        break;
      case 2:
        value = wide(rng);
        break;
      default:
        value = near(rng);
        break;
    }
    const auto result = axis.command(t, value);
    if (!std::isfinite(value)) {
      EXPECT_EQ(result, ptz::SetpointResult::kRejected);
      ++rejected;
    } else if (value < p.min_position || value > p.max_position) {
      EXPECT_EQ(result, ptz::SetpointResult::kClamped);
      ++clamped;
    } else {
      EXPECT_EQ(result, ptz::SetpointResult::kAccepted);
    }
    const double before = axis.position();
    t += dt(rng);
    axis.advanceTo(t, 0.0005);
    ASSERT_TRUE(std::isfinite(axis.position()));
    ASSERT_GE(axis.position(), p.min_position);
    ASSERT_LE(axis.position(), p.max_position);
    ASSERT_LE(std::abs(axis.position() - before), p.max_rate_per_s * 0.05 + 1e-9);
  }
  EXPECT_GT(rejected, 1000);
  EXPECT_GT(clamped, 1000);
}

TEST(Plant, WholeRigCommandCountsClampedAndRejected) {
  ptz::PtzPlant plant(ptz::defaultPlantParams(), {}, {});
  int clamped = 0, rejected = 0;
  plant.command(0, {0.1, 5.0, 1.0}, {std::nan(""), 0.0, 50.0}, &clamped, &rejected);
  EXPECT_EQ(clamped, 2);   // left tilt above 90 deg, right zoom above 10x
  EXPECT_EQ(rejected, 1);  // right pan
  plant.advanceTo(10.0);
  EXPECT_NEAR(plant.pose(ptz::Side::kLeft).pan_rad, 0.1, 1e-9);
  EXPECT_NEAR(plant.pose(ptz::Side::kLeft).tilt_rad, M_PI / 2, 1e-9);
  EXPECT_EQ(plant.pose(ptz::Side::kRight).pan_rad, 0.0);  // the rejected axis held
  EXPECT_NEAR(plant.pose(ptz::Side::kRight).zoom, 10.0, 1e-9);
  EXPECT_TRUE(plant.atLimit(ptz::Side::kLeft));    // tilt at +90 deg
  EXPECT_FALSE(plant.atLimit(ptz::Side::kRight));  // zoom at 10x is not a pan/tilt limit
}

// The plant's parameters: each error names the flag, the parameter and the value, not an axis.
TEST(PlantParams, BadValuesNameTheirFlagAndValue) {
  auto errorOf = [](std::vector<std::string> args) {
    ptz::Params p("prog", "test");
    ptz::addPlantParams(p);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    try {
      p.parse(static_cast<int>(argv.size()), argv.data());
      ptz::plantParamsFrom(p);
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(errorOf({"prog", "--dead-time-s", "-1"}),
            "flag --dead-time-s: parameter 'dead_time_s' must be within 0 .. 60, got '-1'");
  EXPECT_EQ(errorOf({"prog", "--zoom-min", "4", "--zoom-max", "2"}),
            "parameter 'zoom_min' = 4 (flag --zoom-min) must be below parameter 'zoom_max' = 2 "
            "(flag --zoom-max)");
  EXPECT_EQ(errorOf({"prog", "--pan-time-constant-s", "0"}),
            "flag --pan-time-constant-s: parameter 'pan_time_constant_s' must be > 0, got '0'");
  EXPECT_EQ(errorOf({"prog", "--tilt-max-rate", "-3"}),
            "flag --tilt-max-rate: parameter 'tilt_max_rate' must be > 0, got '-3'");
  EXPECT_EQ(errorOf({"prog", "--dead-time-s", "0.2", "--zoom-max", "12"}), "");
}
