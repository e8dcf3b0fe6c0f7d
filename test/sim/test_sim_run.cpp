// ptz-sim's run without LCM (SimRun): setpoints clamped to the limits or rejected and counted,
// the lockstep handshake (the answer to the frame, a stale answer, the timeout), the states on
// the way and the frames' stamps, with known answers.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/plant.hpp"
#include "sim/sim_run.hpp"

namespace sim = ptz::sim;
using ptz::Side;

namespace {

struct LockstepRun {
  std::vector<ptzstereo::ptz_state_t> states;
  sim::SimRun run;

  explicit LockstepRun(double dead_time_s = 0.0, double timeout_ms = 1000)
      : run(makeSimulator(dead_time_s), clock(timeout_ms),
            [this](ptzstereo::ptz_state_t* m) { states.push_back(*m); }) {}

  static std::unique_ptr<sim::Simulator> makeSimulator(double dead_time_s) {
    ptz::PtzPlant::Params plant = ptz::defaultPlantParams();
    for (auto& a : plant.axis) a.dead_time_s = dead_time_s;
    return std::make_unique<sim::Simulator>(ptz::StereoRig::makeDefault(), sim::Scene{}, plant, 0.0,
                                            1);
  }
  static sim::SimClock clock(double timeout_ms) {
    sim::SimClock c;
    c.lockstep = true;
    c.frame_period_s = 0.1;
    c.state_period_s = 0.01;
    c.lockstep_timeout_ms = timeout_ms;
    return c;
  }
};

ptzstereo::ptz_setpoint_t setpoint(int64_t frame_seq, double left_pan_rad, double left_tilt_rad) {
  ptzstereo::ptz_setpoint_t m{};
  m.utime = 42;
  m.frame_seq = frame_seq;
  m.left = {left_pan_rad, left_tilt_rad, 1.0};
  m.right = {0.0, 0.0, 1.0};
  return m;
}

}  // namespace

TEST(SimRun, ASetpointBeyondALimitIsClampedToItAndCounted) {
  LockstepRun r;
  const sim::SetpointOutcome out = r.run.applySetpoint(setpoint(-1, 10.0, 0.0));
  EXPECT_EQ(out.dropped, "");
  EXPECT_EQ(out.clamped, 1);
  EXPECT_EQ(out.rejected, 0);
  r.run.advanceWithStates(6.0);
  const double pan_max = ptz::defaultPlantParams().axis[0].max_position;
  ASSERT_FALSE(r.states.empty());
  EXPECT_NEAR(r.states.back().left.pan_rad, pan_max, 1e-6);
  EXPECT_TRUE(r.states.back().left.at_limit);
}

TEST(SimRun, ANonFiniteValueIsRejectedAndItsAxisHolds) {
  LockstepRun r;
  const sim::SetpointOutcome out = r.run.applySetpoint(setpoint(-1, NAN, 0.1));
  EXPECT_EQ(out.clamped, 0);
  EXPECT_EQ(out.rejected, 1);
  r.run.advanceWithStates(3.0);
  EXPECT_DOUBLE_EQ(r.states.back().left.pan_rad, 0.0);
  EXPECT_NEAR(r.states.back().left.tilt_rad, 0.1, 1e-6);  // e^(-3 s / T) of the step left
}

TEST(SimRun, LockstepStatesComeEveryStatePeriodInSimTime) {
  LockstepRun r;
  r.run.applySetpoint(setpoint(-1, 0.0, 0.0));  // setpoint_utime 42 from now on
  r.run.advanceWithStates(0.1);
  ASSERT_EQ(r.states.size(), 11u);  // 0, 10, ..., 100 ms
  for (size_t k = 0; k < r.states.size(); ++k) {
    EXPECT_EQ(r.states[k].utime, sim::kLockstepEpochUtime + static_cast<int64_t>(k) * 10'000);
    EXPECT_EQ(r.states[k].setpoint_utime, 42);
  }
}

TEST(SimRun, LockstepAdvancesOnTheAnswerToTheFrameAndDropsOthers) {
  LockstepRun r(0.05);
  r.run.advanceWithStates(0.2);
  const sim::SimRun::Capture c = r.run.capture();
  EXPECT_EQ(c.frame.index, 0);
  EXPECT_EQ(c.utime, sim::kLockstepEpochUtime + 200'000);
  EXPECT_EQ(c.truth.utime, c.utime);
  EXPECT_EQ(c.truth.frame_seq, 0);
  ASSERT_FALSE(c.frame.left.empty());
  std::vector<sim::SetpointOutcome> outcomes;
  int serves = 0;
  const sim::Answer answer = r.run.awaitAnswer(0, [&](int) {
    // First an answer to another frame, then the answer to frame 0.
    outcomes.push_back(r.run.applySetpoint(setpoint(serves == 0 ? 5 : 0, 0.5, 0.0)));
    ++serves;
    return true;
  });
  EXPECT_EQ(answer, sim::Answer::kAnswered);
  ASSERT_EQ(outcomes.size(), 2u);
  EXPECT_EQ(outcomes[0].dropped, "setpoint_stale");
  EXPECT_EQ(outcomes[1].dropped, "");
  // Issued at the frame's capture time (0.2 s), it acts tau = 50 ms later: still before 0.25 s.
  r.states.clear();
  r.run.advanceWithStates(0.3);
  for (const auto& s : r.states) {
    const double t_s = (s.utime - sim::kLockstepEpochUtime) * 1e-6;
    if (t_s < 0.2499) {
      EXPECT_DOUBLE_EQ(s.left.pan_rad, 0.0) << t_s;
    } else if (t_s > 0.26) {
      EXPECT_GT(s.left.pan_rad, 0.0) << t_s;
    }
  }
  // Out of the handshake, an answer to any frame is stale.
  EXPECT_EQ(r.run.applySetpoint(setpoint(0, 0.5, 0.0)).dropped, "setpoint_stale");
}

TEST(SimRun, LockstepGivesUpAfterTheTimeoutOrOnStop) {
  LockstepRun r(0.0, 20.0);
  r.run.capture();
  EXPECT_EQ(r.run.awaitAnswer(0,
                              [](int timeout_ms) {
                                EXPECT_LE(timeout_ms, 20);
                                return true;
                              }),
            sim::Answer::kTimedOut);
  EXPECT_EQ(r.run.awaitAnswer(1, [](int) { return false; }), sim::Answer::kStopped);
}
