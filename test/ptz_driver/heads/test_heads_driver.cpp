// ptz-driver's per-message rules (HeadsDriver) on two recording heads: clamps, non-finite
// refusal, the deadman's hold, PTZ_STATE from the measurements, the status's sums.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "ptz_driver/heads/heads_driver.hpp"
#include "ptzstereo/process_status_t.hpp"

using namespace ptz::driver;
using ptz::PtzPose;

namespace {
// A head that records what it is told and measures what the test says.
class RecordingHead : public PtzHead {
 public:
  void start(double) override { ++starts; }
  void command(const PtzPose& pose, double) override { commands.push_back(pose); }
  bool stop(double, double) override {
    ++stops;
    return true;
  }
  void inquire(double, double) override { ++inquiries; }
  void receive(double) override {}
  std::optional<PtzPose> measured() const override { return pose; }
  double measuredAtS() const override { return at_s; }
  int fd() const override { return -1; }
  HeadStats& stats() override { return stats_; }

  std::optional<PtzPose> pose;
  double at_s = 0;
  std::vector<PtzPose> commands;
  int starts = 0, stops = 0, inquiries = 0;
  HeadStats stats_;
};

struct Rig {
  RecordingHead* left;
  RecordingHead* right;
  std::unique_ptr<HeadsDriver> driver;
};

// Limits pan [-1, 1], tilt [-0.5, 0.5], zoom [1, 4]; slew 2 rad/s; deadman 0.25 s.
Rig makeRig() {
  HeadsDriver::Settings s;
  s.limits.axis[0].min_position = -1;
  s.limits.axis[0].max_position = 1;
  s.limits.axis[1].min_position = -0.5;
  s.limits.axis[1].max_position = 0.5;
  s.limits.axis[2].min_position = 1;
  s.limits.axis[2].max_position = 4;
  s.max_setpoint_rate = 2.0;
  s.deadman_s = 0.25;
  auto l = std::make_unique<RecordingHead>(), r = std::make_unique<RecordingHead>();
  Rig rig{l.get(), r.get(), nullptr};
  rig.driver = std::make_unique<HeadsDriver>(
      std::array<std::unique_ptr<PtzHead>, 2>{std::move(l), std::move(r)}, s);
  return rig;
}

ptzstereo::ptz_setpoint_t setpoint(double pan, double tilt, double zoom) {
  ptzstereo::ptz_setpoint_t m{};
  m.utime = 1234;
  m.left = {pan, tilt, zoom};
  m.right = {0.0, 0.0, 1.0};
  return m;
}
}  // namespace

TEST(HeadsDriver, ClampsASetpointBeyondTheLimits) {
  Rig rig = makeRig();
  rig.left->pose = PtzPose{0.9, 0.45, 1.0};
  rig.right->pose = PtzPose{0.0, 0.0, 1.0};
  ASSERT_TRUE(rig.driver->acceptSetpoint(setpoint(5.0, 3.0, 50.0), 10.0));
  EXPECT_FALSE(rig.driver->tick(10.05, 0.1));  // a slew step of 0.2 rad
  ASSERT_EQ(rig.left->commands.size(), 1u);
  EXPECT_DOUBLE_EQ(rig.left->commands[0].pan_rad, 1.0);  // 0.9 + 0.2, clamped at 1
  EXPECT_DOUBLE_EQ(rig.left->commands[0].tilt_rad, 0.5);
  EXPECT_DOUBLE_EQ(rig.left->commands[0].zoom, 4.0);
  EXPECT_EQ(rig.left->inquiries, 1);
}

TEST(HeadsDriver, RefusesANonFiniteSetpointAndMovesNoHead) {
  Rig rig = makeRig();
  rig.left->pose = rig.right->pose = PtzPose{0.0, 0.0, 1.0};
  auto m = setpoint(0.5, 0.0, 1.0);
  m.right.tilt_rad = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(rig.driver->acceptSetpoint(m, 10.0));
  m.right.tilt_rad = 0.0;
  m.left.zoom = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(rig.driver->acceptSetpoint(m, 10.0));
  rig.driver->tick(10.05, 0.1);
  EXPECT_TRUE(rig.left->commands.empty());
  EXPECT_TRUE(rig.right->commands.empty());
}

TEST(HeadsDriver, HoldsWhereMeasuredOnceWithoutAFreshSetpoint) {
  Rig rig = makeRig();
  rig.left->pose = rig.right->pose = PtzPose{0.0, 0.0, 1.0};
  ASSERT_TRUE(rig.driver->acceptSetpoint(setpoint(1.0, 0.0, 1.0), 10.0));
  EXPECT_FALSE(rig.driver->tick(10.1, 0.1));  // within deadman_s: toward the setpoint
  rig.left->pose = PtzPose{0.15, 0.0, 1.0};
  EXPECT_TRUE(rig.driver->tick(10.3, 0.1));  // 0.3 s after it: the hold, once
  EXPECT_DOUBLE_EQ(rig.left->commands.back().pan_rad, 0.15);
  EXPECT_FALSE(rig.driver->tick(10.4, 0.1));
  EXPECT_DOUBLE_EQ(rig.left->commands.back().pan_rad, 0.15);
  EXPECT_EQ(rig.left->stops, 0);  // its position was known: commanded, not stopped
  ASSERT_TRUE(rig.driver->acceptSetpoint(setpoint(1.0, 0.0, 1.0), 10.5));
  rig.driver->tick(10.5, 0.1);
  EXPECT_DOUBLE_EQ(rig.left->commands.back().pan_rad, 0.35);  // moving again from the hold
}

TEST(HeadsDriver, StopsAHeadOfUnknownPositionOnTheHold) {
  Rig rig = makeRig();
  ASSERT_TRUE(rig.driver->acceptSetpoint(setpoint(1.0, 0.0, 1.0), 10.0));
  EXPECT_TRUE(rig.driver->tick(10.3, 0.1));
  EXPECT_EQ(rig.left->stops, 1);
  EXPECT_EQ(rig.right->stops, 1);
  EXPECT_TRUE(rig.left->commands.empty());
}

TEST(HeadsDriver, PublishesEachNewMeasurementOnce) {
  Rig rig = makeRig();
  rig.left->pose = PtzPose{0.1, 0.2, 2.0};
  EXPECT_FALSE(rig.driver->newState()) << "the right head measured nothing yet";
  rig.right->pose = PtzPose{-0.1, -0.2, 3.0};
  rig.left->at_s = 20.5;
  rig.right->at_s = 20.25;
  ASSERT_TRUE(rig.driver->acceptSetpoint(setpoint(0.0, 0.0, 1.0), 20.0));
  const auto state = rig.driver->newState();
  ASSERT_TRUE(state);
  EXPECT_EQ(state->utime, 20'250'000);  // the older of the two
  EXPECT_EQ(state->setpoint_utime, 1234);
  EXPECT_DOUBLE_EQ(state->left.tilt_rad, 0.2);
  EXPECT_DOUBLE_EQ(state->right.zoom, 3.0);
  EXPECT_FALSE(rig.driver->newState()) << "nothing new";
}

TEST(HeadsDriver, SumsTheHeadsCountersAndSaysWhatIsWrong) {
  Rig rig = makeRig();
  rig.left->stats_.timeouts = 2;
  rig.right->stats_.timeouts = 3;
  rig.right->stats_.round_trip_ms = {4.0, 6.0};
  rig.right->stats_.last_error = "syntax";
  HeadsReport r = rig.driver->report(5.0);
  EXPECT_EQ(r.counters[0], (std::pair<std::string, int64_t>{"head_timeouts", 5}));
  EXPECT_EQ(r.round_trip_ms, (std::vector<double>{4.0, 6.0}));
  EXPECT_TRUE(rig.right->stats_.round_trip_ms.empty()) << "read once";
  EXPECT_EQ(r.head_errors, std::vector<std::string>{"syntax"});
  EXPECT_EQ(r.state, ptzstereo::process_status_t::STATE_ERROR);
  EXPECT_EQ(r.message, "no position replies from a head for 1 s");
  rig.left->pose = rig.right->pose = PtzPose{0.0, 0.0, 1.0};
  rig.left->at_s = rig.right->at_s = 4.5;
  EXPECT_EQ(rig.driver->report(5.0).state, ptzstereo::process_status_t::STATE_OK);
}
