// ptz-control's work on one OBJECT_TRACKS (TracksFollower), its parameters and the delay status:
// what a message makes of the setpoint, the control state and the counters, with known answers.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/config.hpp"
#include "control/controller/control_params.hpp"
#include "control/controller/delay_monitor.hpp"
#include "control/controller/pointing.hpp"
#include "control/controller/tracks_follower.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace control = ptz::control;
using ptzstereo::control_state_t;
using ptzstereo::object_track_t;

namespace {

constexpr int64_t kStartUtime = 1'000'000;  // t = 1 s

control::ControllerParams trackHoldingZoom() {
  control::ControllerParams p;
  p.max_setpoint_rate = 1000;  // no slew limit: the setpoint is the aim
  p.zoom_mode = "hold";
  return p;
}

// A tracks message at utime for frame seq, the heads at home, the target (id 4) at position_m
// in the given track state.
ptzstereo::object_tracks_t tracks(int64_t utime, int64_t seq, const Eigen::Vector3d& position_m,
                                  int8_t state) {
  ptzstereo::object_tracks_t m{};
  m.utime = utime;
  m.frame_seq = seq;
  m.left_ptz = {0, 0, 1};
  m.right_ptz = {0, 0, 1};
  object_track_t t{};
  t.id = 4;
  t.state = state;
  t.radius_m = 0.1;
  for (int k = 0; k < 3; ++k) t.position_m[k] = position_m[k];
  m.tracks = {t};
  m.num_tracks = 1;
  m.target_id = 4;
  return m;
}

std::vector<std::string> counters(const control::TracksAnswer& a) {
  std::vector<std::string> names;
  for (const auto& e : a.events) names.push_back(e.counter);
  return names;
}

void expectAimedAt(const StereoRig& rig, const ptzstereo::ptz_setpoint_t& sp,
                   const Eigen::Vector3d& p) {
  for (Side side : {Side::kLeft, Side::kRight}) {
    double pan = 0, tilt = 0;
    ASSERT_TRUE(
        control::aimAt(rig, side, p, 1.0, control::imageCentre(rig.camera(side)), &pan, &tilt));
    const auto& head = side == Side::kLeft ? sp.left : sp.right;
    EXPECT_NEAR(head.pan_rad, pan, 1e-9);
    EXPECT_NEAR(head.tilt_rad, tilt, 1e-9);
    EXPECT_DOUBLE_EQ(head.zoom, 1.0);  // held
  }
}

}  // namespace

TEST(TracksFollower, ACoastingTargetIsFollowedOnItsPredictionThenSearchedFor) {
  const StereoRig rig = StereoRig::makeDefault();
  control::TracksFollower follower(rig, trackHoldingZoom());
  const Eigen::Vector3d seen(0.3, 0.1, 3.0), predicted(0.5, 0.1, 3.0);

  const auto first =
      follower.follow(tracks(kStartUtime, 10, seen, object_track_t::STATE_CONFIRMED));
  ASSERT_FALSE(first.dropped);
  EXPECT_EQ(first.setpoint.utime, kStartUtime);
  EXPECT_EQ(first.setpoint.frame_seq, 10);
  expectAimedAt(rig, first.setpoint, seen);
  EXPECT_EQ(first.state.state, control_state_t::STATE_TRACKING);
  EXPECT_EQ(first.state.reason, "tracking");
  EXPECT_TRUE(first.reason_changed);
  EXPECT_EQ(counters(first),
            (std::vector<std::string>{"setpoints_tracking", "setpoints_tracking"}));

  // Hidden 0.1 s later: the heads follow the track's prediction (the track mode's aim at it).
  const auto hidden =
      follower.follow(tracks(kStartUtime + 100'000, 13, predicted, object_track_t::STATE_COASTING));
  expectAimedAt(rig, hidden.setpoint, predicted);
  EXPECT_EQ(hidden.setpoint.frame_seq, 13);
  EXPECT_EQ(hidden.state.state, control_state_t::STATE_COASTING);
  EXPECT_EQ(hidden.state.target_id, 4);
  EXPECT_NEAR(hidden.state.since_target_s, 0.1, 1e-9);
  EXPECT_EQ(hidden.state.search_waypoint, -1);
  EXPECT_EQ(hidden.state.reason, "target hidden: following its prediction");
  EXPECT_TRUE(hidden.reason_changed);
  EXPECT_EQ(counters(hidden),
            (std::vector<std::string>{"setpoints_without_target", "setpoints_coasting"}));
  const auto again =
      follower.follow(tracks(kStartUtime + 133'000, 14, predicted, object_track_t::STATE_COASTING));
  EXPECT_FALSE(again.reason_changed);

  // Past coast_s (2 s) after it was last measured: the search.
  const auto lost = follower.follow(
      tracks(kStartUtime + 2'200'000, 80, predicted, object_track_t::STATE_COASTING));
  EXPECT_EQ(lost.state.state, control_state_t::STATE_SEARCHING);
  EXPECT_GE(lost.state.search_waypoint, 0);
  EXPECT_GT(lost.state.search_waypoints, 0);
  EXPECT_EQ(counters(lost),
            (std::vector<std::string>{"setpoints_without_target", "setpoints_searching"}));
}

TEST(TracksFollower, ATargetIdOfNoTrackIsCountedAndTheHeadsHold) {
  control::TracksFollower follower(StereoRig::makeDefault(), trackHoldingZoom());
  auto m = tracks(kStartUtime, 1, {0.3, 0.1, 3.0}, object_track_t::STATE_CONFIRMED);
  m.target_id = 7;
  m.left_ptz = {0.2, -0.1, 1.5};
  const auto a = follower.follow(m);
  ASSERT_FALSE(a.dropped);
  ASSERT_EQ(a.events.size(), 3u);
  EXPECT_EQ(a.events[0].counter, "target_not_in_tracks");
  EXPECT_EQ(a.events[0].message, "target_id 7: none of the message's tracks: no target");
  EXPECT_EQ(a.state.state, control_state_t::STATE_HOLDING);
  EXPECT_EQ(a.state.target_id, -1);
  // The first setpoint is where the heads are.
  EXPECT_DOUBLE_EQ(a.setpoint.left.pan_rad, 0.2);
  EXPECT_DOUBLE_EQ(a.setpoint.left.tilt_rad, -0.1);
  EXPECT_DOUBLE_EQ(a.setpoint.left.zoom, 1.5);
}

TEST(TracksFollower, ATrackStateOfNoKindIsCounted) {
  control::TracksFollower follower(StereoRig::makeDefault(), trackHoldingZoom());
  const auto a = follower.follow(tracks(kStartUtime, 1, {0.3, 0.1, 3.0}, 5));
  ASSERT_FALSE(a.events.empty());
  EXPECT_EQ(a.events[0].counter, "target_bad_state");
  EXPECT_EQ(a.events[0].message, "target_id 4: a track state none of 0, 1, 2: no target");
  EXPECT_EQ(a.state.target_id, -1);
}

TEST(TracksFollower, ImplausibleTargetsAreIgnored) {
  control::TracksFollower follower(StereoRig::makeDefault(), trackHoldingZoom());
  // Behind both cameras.
  const auto behind =
      follower.follow(tracks(kStartUtime, 1, {0.0, 0.0, -3.0}, object_track_t::STATE_CONFIRMED));
  EXPECT_EQ(counters(behind),
            (std::vector<std::string>{"implausible_poses", "setpoints_without_target",
                                      "setpoints_holding"}));
  EXPECT_EQ(behind.state.target_id, -1);
  EXPECT_DOUBLE_EQ(behind.setpoint.left.pan_rad, 0.0);  // held where the heads are
  // In front, but at 100 m/s.
  auto fast = tracks(kStartUtime + 33'000, 2, {0.3, 0.1, 3.0}, object_track_t::STATE_CONFIRMED);
  fast.tracks[0].velocity_m_s[0] = 100;
  const auto a = follower.follow(fast);
  ASSERT_FALSE(a.events.empty());
  EXPECT_EQ(a.events[0].counter, "implausible_poses");
  EXPECT_EQ(a.state.state, control_state_t::STATE_HOLDING);
}

TEST(TracksFollower, ANonFiniteCameraPoseDropsTheMessage) {
  control::TracksFollower follower(StereoRig::makeDefault(), trackHoldingZoom());
  auto m = tracks(kStartUtime, 1, {0.3, 0.1, 3.0}, object_track_t::STATE_CONFIRMED);
  m.right_ptz.tilt_rad = NAN;
  const auto a = follower.follow(m);
  ASSERT_TRUE(a.dropped);
  EXPECT_EQ(a.dropped->counter, "nonfinite_ptz");
  EXPECT_TRUE(a.events.empty());
}

TEST(DelayMonitor, FeedsTheStatusEveryThirtySetpoints) {
  control::DelayMonitor monitor({1.7, 0.24, 0.0}, 0.05, 30.0);
  for (int i = 1; i < 30; ++i) EXPECT_FALSE(monitor.feed(0.01));
  const auto s = monitor.feed(0.01);
  ASSERT_TRUE(s);
  ASSERT_EQ(s->counters.size(), 3u);
  EXPECT_EQ(s->counters[0], std::make_pair(std::string("delay_us_p50"), int64_t{60'000}));
  EXPECT_EQ(s->counters[1], std::make_pair(std::string("delay_us_p99"), int64_t{60'000}));
  EXPECT_EQ(s->counters[2].first, "phase_margin_millideg");
  EXPECT_EQ(s->warning, "");
  EXPECT_EQ(monitor.samples(), 0u);
}

TEST(DelayMonitor, InSmithModeWarnsOfAModelDelayOffByOverTenPercent) {
  // The model assumes 200 ms; 10 ms measured + 50 ms dead time = 60 ms.
  control::DelayMonitor monitor({1.7, 0.24, 0.0}, 0.05, 30.0, 0.2);
  std::optional<control::DelayMonitor::Status> s;
  for (int i = 0; i < 30; ++i) s = monitor.feed(0.01);
  ASSERT_TRUE(s);
  ASSERT_EQ(s->counters.size(), 4u);
  EXPECT_EQ(s->counters[3], std::make_pair(std::string("smith_delay_error_us"), int64_t{-140'000}));
  EXPECT_EQ(
      s->warning,
      "measured delay p50 60.0 ms, the smith model assumes 200.0 ms: set smith_extra_delay_s");
  // 210 ms measured in all: within 10 %.
  for (int i = 0; i < 30; ++i) s = monitor.feed(0.16);
  EXPECT_EQ(s->warning, "");
}

namespace {

ptz::Params controlParams(std::vector<std::string> args) {
  ptz::Params p("ptz-control", "test");
  control::declareControlParams(p);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  p.parse(static_cast<int>(argv.size()), argv.data());
  return p;
}

}  // namespace

TEST(ControlParams, TheSearchRegionKeepsWithinTheAxisLimits) {
  const auto c = control::controllerParamsFrom(
      controlParams({"ptz-control", "--pan-min", "-1", "--search-tilt-max-rad", "0.5"}));
  EXPECT_DOUBLE_EQ(c.search.pan_min_rad, -1.0);  // the axis limit, not the default -2.97
  EXPECT_DOUBLE_EQ(c.search.tilt_max_rad, 0.5);  // within tilt_max: as given
  EXPECT_EQ(c.mode, "track");
  EXPECT_THROW(control::controllerParamsFrom(controlParams({"ptz-control", "--mode", "fast"})),
               ptz::ConfigError);
}
