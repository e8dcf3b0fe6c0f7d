// The run's numbers on made-up runs whose answers are known by construction: a target behind a
// camera or near 90 degrees off its axis, frames never answered, a run without a pose, the
// tracked object by identity, poses before their truth in any order, search and coast times;
// and ptz-log-summary's JSON and CSV of a logged run.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <sstream>

#include "support/run_program.hpp"
#include "tools/logs/run_metrics.hpp"
#include "tools/logs/synthetic_run.hpp"

using ptz::tools::RunMetrics;
using ptzstereo::control_state_t;
namespace syn = ptz::test::synthetic;

namespace {

const syn::Object kBall{"ball", "red_ball", {0, 0, 2}};
// The centred ball's offset in each camera: half the baseline at 2 m.
constexpr double kCentredPx = syn::kFocalPx * syn::kHalfBaselineM / 2;

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + "run_metrics_" + name;
}

}  // namespace

TEST(RunMetrics, ATargetBehindACameraIsOutsideTheImageAndNotInTheCentring) {
  RunMetrics m("red_ball", 0.0);
  for (int64_t seq = 0; seq < 4; ++seq) {
    syn::Object ball = kBall;
    if (seq == 2) ball.position_m = {0, 0, -2};  // behind both cameras
    m.onTruth(syn::truth(seq, {ball}));
  }
  m.onPose(syn::pose(0, "red_ball", kBall.position_m));  // locked from the first frame
  const auto s = m.summary();
  EXPECT_EQ(s.frames_target_outside_image, 1);
  EXPECT_EQ(s.centering_samples, 6);  // both cameras of frames 0, 1 and 3
  EXPECT_NEAR(s.centering_rms_px, kCentredPx, 1e-9);
  EXPECT_NEAR(s.centering_max_px, kCentredPx, 1e-9);
  EXPECT_EQ(m.centeringByFrame().count(2), 0u);
}

// Centring counts from settle_s after the first lock: not while the heads search (here the ball
// 1 m off to the side), nor while they turn to it; a run that never locks has no centring.
TEST(RunMetrics, CentringStartsSettleAfterTheFirstLock) {
  RunMetrics m("red_ball", 0.25);  // 2.5 frames of 0.1 s
  for (int64_t seq = 0; seq < 20; ++seq) {
    syn::Object ball = kBall;
    if (seq < 10) ball.position_m = {1.0, 0, 2};
    m.onTruth(syn::truth(seq, {ball}));
    if (seq < 8) m.onPose(syn::pose(seq));  // searching: no target
    // The first two poses 2 cm off (zooming in), then exact.
    std::array<double, 3> estimate = ball.position_m;
    if (seq == 8 || seq == 9) estimate[2] += 0.02;
    if (seq >= 8) m.onPose(syn::pose(seq, "red_ball", estimate));
  }
  const auto centring = m.centeringByFrame();
  ASSERT_FALSE(centring.empty());
  EXPECT_EQ(centring.begin()->first, 11);  // locked at 8, 0.25 s later
  const auto s = m.summary();
  EXPECT_EQ(s.centering_samples, 2 * 9);
  EXPECT_NEAR(s.centering_rms_px, kCentredPx, 1e-9);
  EXPECT_NEAR(s.time_to_acquire_s, 0.8, 1e-6);
  // Frames 8 and 9: the ball at (1, 0, 2), sqrt(5) m away; 12 poses in all.
  EXPECT_NEAR(s.position_error_rms_pct_of_range, 100 * 0.02 / std::sqrt(5.0) * std::sqrt(2.0 / 12),
              1e-6);
  EXPECT_NEAR(s.position_error_settled_rms_pct_of_range, 0, 1e-9);  // from frame 11 on
  RunMetrics never("red_ball", 0.0);
  for (int64_t seq = 0; seq < 5; ++seq) {
    never.onTruth(syn::truth(seq, {kBall}));
    never.onPose(syn::pose(seq));
  }
  EXPECT_TRUE(std::isnan(never.summary().centering_rms_px));
  EXPECT_EQ(never.summary().centering_samples, 0);
}

// The same scene seen at 1080p (the cameras' field of view kept): the same VGA-equivalent offset.
TEST(RunMetrics, CentringIsInVgaEquivalentPixelsAtEveryResolution) {
  syn::Object ball = kBall;
  ball.position_m = {0.3, -0.2, 2.5};
  ptzstereo::sim_truth_t vga = syn::truth(0, {ball});
  ptzstereo::sim_truth_t hd = vga;
  for (auto* cam : {&hd.left_camera, &hd.right_camera}) {
    cam->width = 1920;
    cam->height = 1440;
    cam->fx_px *= 3;
    cam->fy_px *= 3;
    cam->cx_px = (cam->cx_px + 0.5) * 3 - 0.5;
    cam->cy_px = (cam->cy_px + 0.5) * 3 - 0.5;
  }
  RunMetrics at_vga("red_ball", 0.0), at_hd("red_ball", 0.0);
  at_vga.onTruth(vga);
  at_hd.onTruth(hd);
  at_vga.onPose(syn::pose(0, "red_ball", ball.position_m));
  at_hd.onPose(syn::pose(0, "red_ball", ball.position_m));
  const auto a = at_vga.centeringByFrame().at(0), b = at_hd.centeringByFrame().at(0);
  ASSERT_EQ(a.size(), 4u);
  ASSERT_EQ(b.size(), 4u);
  for (size_t i = 0; i < 4; ++i) EXPECT_NEAR(b[i], a[i], 1e-9) << i;
  EXPECT_GT(std::abs(a[0]), 50);  // off the centre, so the scale shows
  EXPECT_NEAR(at_hd.summary().centering_rms_px, at_vga.summary().centering_rms_px, 1e-9);
}

TEST(RunMetrics, ATargetNearlyNinetyDegreesOffTheAxisIsAPinholeOffsetNotAnAbsurdOne) {
  // The simulator's barrel distortion: its polynomial gives ~1e9 px this far out.
  ptzstereo::sim_truth_t t = syn::truth(0, {});
  for (auto* cam : {&t.left_camera, &t.right_camera}) {
    const double k[5] = {-0.12, 0.04, 0.0004, -0.0003, 0};
    std::copy(k, k + 5, cam->distortion);
  }
  const double angle = 88 * M_PI / 180;
  ptzstereo::sim_object_truth_t o{};
  o.name = "ball";
  o.class_name = "red_ball";
  o.position_m[0] = 2 * std::sin(angle) - syn::kHalfBaselineM;  // 88 deg off the left axis
  o.position_m[2] = 2 * std::cos(angle);
  t.objects = {o};
  t.num_objects = 1;
  RunMetrics m("red_ball", 0.0);
  m.onTruth(t);
  m.onPose(syn::pose(0, "red_ball", {o.position_m[0], o.position_m[1], o.position_m[2]}));
  const auto s = m.summary();
  EXPECT_EQ(s.frames_target_outside_image, 1);
  EXPECT_EQ(s.centering_samples, 2);
  EXPECT_NEAR(s.centering_max_px, syn::kFocalPx * std::tan(angle), 1e-6);  // 14318 px
}

TEST(RunMetrics, FramesTheDetectorNeverAnsweredCountAsLost) {
  RunMetrics m("red_ball", 0.0);
  for (int64_t seq = 0; seq < 10; ++seq) {
    m.onFrame(syn::frame(seq));
    m.onTruth(syn::truth(seq, {kBall}));
    if (seq == 3) m.onPose(syn::pose(seq));
    if (seq <= 5 && seq != 3) m.onPose(syn::pose(seq, "red_ball", kBall.position_m));
  }
  const auto s = m.summary();
  EXPECT_EQ(s.frames_published, 10);
  EXPECT_EQ(s.frames_processed, 6);
  EXPECT_EQ(s.poses_without_target, 1);
  EXPECT_EQ(s.frames_without_pose, 4);
  EXPECT_NEAR(s.target_lost_s, 0.5, 1e-9);  // 4 unanswered + 1 without a target, at 10 Hz
  EXPECT_NEAR(s.time_to_acquire_s, 0.0, 1e-9);
  EXPECT_NEAR(s.position_error_rms_m, 0.0, 1e-12);
}

TEST(RunMetrics, ARunWithoutAnyPoseIsLostForItsWholeDuration) {
  RunMetrics m("red_ball", 0.0);
  for (int64_t seq = 0; seq < 20; ++seq) m.onTruth(syn::truth(seq, {kBall}));
  auto s = m.summary();
  EXPECT_EQ(s.frames_published, 20);  // seen in SIM_TRUTH
  EXPECT_EQ(s.frames_processed, 0);
  EXPECT_EQ(s.frames_without_pose, 20);
  EXPECT_NEAR(s.target_lost_s, 2.0, 1e-9);
  EXPECT_TRUE(std::isnan(s.time_to_acquire_s));
  EXPECT_NE(s.toJson().find("\"time_to_acquire_s\": null"), std::string::npos) << s.toJson();
  EXPECT_TRUE(std::isnan(s.search_time_s));  // no CONTROL_STATE: unknown, not 0
  // The simulator published 25: the 5 this listener never saw were not answered either.
  ptzstereo::process_status_t status{};
  status.process = "ptz-sim";
  status.counters.push_back({"frames_published", 25});
  status.num_counters = 1;
  m.onStatus(status);
  s = m.summary();
  EXPECT_EQ(s.frames_without_pose, 25);
  EXPECT_NEAR(s.target_lost_s, 2.5, 1e-9);
}

TEST(RunMetrics, TheTrackedObjectIsScoredByIdentityAndASwitchIsCounted) {
  // ball_b first in SIM_TRUTH; a green box nearer to the estimate than ball_a is.
  const std::vector<syn::Object> objects = {{"ball_b", "red_ball", {0.5, 0, 2}},
                                            {"box", "green_box", {0.012, 0, 2}},
                                            {"ball_a", "red_ball", {0, 0, 2}}};
  RunMetrics m("red_ball", 0.0);
  for (int64_t seq = 0; seq < 12; ++seq) {
    m.onTruth(syn::truth(seq, objects));
    if (seq < 2) m.onPose(syn::pose(seq));
    if (seq >= 2 && seq <= 6) m.onPose(syn::pose(seq, "red_ball", {0.01, 0, 2}));
    if (seq >= 7) m.onPose(syn::pose(seq, "red_ball", {0.5, 0, 2.02}));
  }
  const auto s = m.summary();
  EXPECT_EQ(s.target_switches, 1);
  EXPECT_EQ(s.position_samples, 10);
  EXPECT_NEAR(s.position_error_rms_m, std::sqrt((5 * 0.01 * 0.01 + 5 * 0.02 * 0.02) / 10), 1e-9);
  const double pct_a = 100 * 0.01 / 2, pct_b = 100 * 0.02 / std::hypot(0.5, 2.0);
  EXPECT_NEAR(s.position_error_rms_pct_of_range,
              std::sqrt((5 * pct_a * pct_a + 5 * pct_b * pct_b) / 10), 1e-9);
  const auto frames = m.frames();
  EXPECT_EQ(frames.at(1).tracked, "");
  EXPECT_EQ(frames.at(3).tracked, "ball_a");
  EXPECT_EQ(frames.at(8).tracked, "ball_b");
  EXPECT_EQ(frames.at(8).tracked_truth_m[0], 0.5);
  // Centring: from the first lock (frame 2: settle_s is 0 here), of the one tracked; none before.
  const auto centring = m.centeringByFrame();
  const double b_left = syn::kFocalPx * 0.55 / 2, b_right = syn::kFocalPx * 0.45 / 2;
  EXPECT_EQ(centring.count(0), 0u);
  EXPECT_EQ(centring.count(1), 0u);
  EXPECT_NEAR(centring.at(2)[0], kCentredPx, 1e-9);
  EXPECT_NEAR(centring.at(4)[0], kCentredPx, 1e-9);
  EXPECT_NEAR(centring.at(4)[2], -kCentredPx, 1e-9);
  EXPECT_NEAR(centring.at(9)[0], b_left, 1e-9);
  EXPECT_NEAR(centring.at(9)[2], b_right, 1e-9);
}

TEST(RunMetrics, ReacquisitionIsTimedFromTheFrameTheObjectIsFullyVisibleAgain) {
  RunMetrics m("red_ball", 0.0);
  // 0-9 seen; 10-19 hidden; 20-29 visible again, the target from 23 on: 0.3 s. 30-39 partly out
  // of the left image (the disk of its radius crosses the border) but the target; 40-49 back in,
  // the target at once: 0 s. 50-54 hidden, 55-59 visible, never the target again: at least 0.4 s.
  for (int64_t seq = 0; seq < 60; ++seq) {
    syn::Object ball = kBall;
    if ((seq >= 10 && seq < 20) || (seq >= 50 && seq < 55)) ball.visible_fraction = 0.3;
    // Centre inside the left image, 315 px right of its centre; the radius is 12.5 px there.
    if (seq >= 30 && seq < 40)
      ball.position_m = {-syn::kHalfBaselineM + 315 * 2 / syn::kFocalPx, 0, 2};
    m.onTruth(syn::truth(seq, {ball}));
    const bool target = seq < 10 || (seq >= 23 && seq < 50);
    m.onPose(target ? syn::pose(seq, "red_ball", ball.position_m) : syn::pose(seq));
  }
  auto s = m.summary();
  EXPECT_EQ(s.reappearances, 3);
  EXPECT_NEAR(s.reacquire_max_s, 0.4, 1e-9);
  EXPECT_NE(s.toJson().find("\"reacquire_max_s\": 0.4"), std::string::npos) << s.toJson();
  // Without the last loss the longest is the first one's 0.3 s.
  RunMetrics first("red_ball", 0.0);
  for (int64_t seq = 0; seq < 30; ++seq) {
    syn::Object ball = kBall;
    if (seq >= 10 && seq < 20) ball.visible_fraction = 0;
    first.onTruth(syn::truth(seq, {ball}));
    first.onPose(seq < 10 || seq >= 23 ? syn::pose(seq, "red_ball", ball.position_m)
                                       : syn::pose(seq));
  }
  s = first.summary();
  EXPECT_EQ(s.reappearances, 1);
  EXPECT_NEAR(s.reacquire_max_s, 0.3, 1e-9);
  // Never hidden: no number.
  RunMetrics never("red_ball", 0.0);
  for (int64_t seq = 0; seq < 5; ++seq) {
    never.onTruth(syn::truth(seq, {kBall}));
    never.onPose(syn::pose(seq, "red_ball", kBall.position_m));
  }
  EXPECT_EQ(never.summary().reappearances, 0);
  EXPECT_TRUE(std::isnan(never.summary().reacquire_max_s));
}

TEST(RunMetrics, APoseBeforeItsTruthIsScoredAndTheArrivalOrderDoesNotMatter) {
  // 30 frames of two balls crossing; every kind of message, then fed in three orders.
  std::vector<std::function<void(RunMetrics&)>> messages;
  int64_t with_target = 0;
  for (int64_t seq = 0; seq < 30; ++seq) {
    const double x = 0.02 * seq;
    const std::vector<syn::Object> objects = {{"ball_a", "red_ball", {x, 0.1, 2.5}},
                                              {"ball_b", "red_ball", {0.6 - x, -0.1, 2.5}}};
    const auto truth = syn::truth(seq, objects);
    const auto pose = seq % 7 == 3
                          ? syn::pose(seq)
                          : syn::pose(seq, "red_ball", {(seq < 15 ? x : 0.6 - x) + 0.003, 0, 2.5});
    with_target += pose.target_index >= 0;
    const int8_t state =
        seq < 4 ? control_state_t::STATE_SEARCHING : control_state_t::STATE_TRACKING;
    messages.push_back([=](RunMetrics& m) { m.onFrame(syn::frame(seq)); });
    messages.push_back([=](RunMetrics& m) { m.onTruth(truth); });
    messages.push_back([=](RunMetrics& m) { m.onPose(pose); });
    messages.push_back([=](RunMetrics& m) { m.onSetpoint(syn::setpoint(seq)); });
    messages.push_back([=](RunMetrics& m) { m.onControlState(syn::control(seq, state)); });
  }
  const auto run = [&](const std::vector<std::function<void(RunMetrics&)>>& order) {
    RunMetrics m("red_ball", 0.5);
    for (const auto& f : order) f(m);
    return m.summary();
  };
  const auto in_order = run(messages);
  EXPECT_EQ(in_order.position_samples, with_target);
  EXPECT_EQ(in_order.target_switches, 1);
  auto reversed = messages;  // every pose before its truth, every setpoint before its frame
  std::reverse(reversed.begin(), reversed.end());
  const auto backwards = run(reversed);
  EXPECT_EQ(backwards.position_samples, with_target);
  EXPECT_EQ(backwards.toJson(), in_order.toJson());
  auto shuffled = messages;
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937(7));
  EXPECT_EQ(run(shuffled).toJson(), in_order.toJson());
}

TEST(RunMetrics, SearchAndCoastTimesComeFromControlState) {
  const int8_t S = control_state_t::STATE_SEARCHING, T = control_state_t::STATE_TRACKING,
               C = control_state_t::STATE_COASTING;
  const int8_t states[10] = {S, S, S, T, T, C, C, S, T, T};
  RunMetrics m("red_ball", 0.0);
  for (int64_t seq = 0; seq < 10; ++seq) {
    m.onTruth(syn::truth(seq, {kBall}));
    m.onPose(seq < 3 ? syn::pose(seq) : syn::pose(seq, "red_ball", kBall.position_m));
    m.onControlState(syn::control(seq, states[seq]));
  }
  const auto s = m.summary();
  EXPECT_NEAR(s.search_time_s, 0.4, 1e-9);
  EXPECT_NEAR(s.coast_time_s, 0.2, 1e-9);
  EXPECT_NEAR(s.time_to_acquire_s, 0.3, 1e-9);
  EXPECT_EQ(m.frames().at(5).control_state, C);
  EXPECT_NE(s.toJson().find("\"search_time_s\": 0.4,"), std::string::npos) << s.toJson();
}

TEST(LogSummary, TheRunsNumbersAndThePerFrameCsvOfALoggedRun) {
  const std::string log = tempPath("known.lcmlog"), json = tempPath("known.json"),
                    csv = tempPath("known.csv");
  syn::writeKnownRun(log);
  const auto r = ptz::test::runProgram(
      {PTZ_LOG_SUMMARY_BIN, "--log", log, "--json", json, "--csv", csv, "--settle-s", "0"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream j(json);
  const std::string summary((std::istreambuf_iterator<char>(j)), std::istreambuf_iterator<char>());
  using K = syn::KnownRun;
  for (const auto& [key, value] :
       std::vector<std::pair<std::string, std::string>>{{"frames_published", "20"},
                                                        {"frames_processed", "18"},
                                                        {"frames_without_pose", "2"},
                                                        {"poses_without_target", "5"},
                                                        {"target_lost_s", "0.7"},
                                                        {"time_to_acquire_s", "0.5"},
                                                        {"search_time_s", "0.3"},
                                                        {"coast_time_s", "0.2"},
                                                        {"target_switches", "1"}}) {
    EXPECT_NE(summary.find("\"" + key + "\": " + value + ","), std::string::npos) << key << " in\n"
                                                                                  << summary;
  }
  const double rms =
      std::sqrt((K::kOnA * K::kErrorAM * K::kErrorAM + K::kOnB * K::kErrorBM * K::kErrorBM) /
                (K::kOnA + K::kOnB));
  const auto at = summary.find("\"position_error_rms_m\": ");
  ASSERT_NE(at, std::string::npos);
  EXPECT_NEAR(std::strtod(summary.c_str() + at + 24, nullptr), rms, 1e-6);
  EXPECT_NE(r.out.find("\"target_switches\": 1"), std::string::npos) << r.out;
  std::ifstream c(csv);
  std::vector<std::string> lines;
  for (std::string line; std::getline(c, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 1u + K::kFrames);
  EXPECT_EQ(lines[0],
            "t_s,frame_seq,left_pan_rad,left_tilt_rad,left_zoom,right_pan_rad,right_tilt_rad,"
            "right_zoom,pose,target,tracked_object,control_state");
  const auto ends = [](const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
  };
  EXPECT_TRUE(ends(lines[1 + 0], ",0,0,,")) << lines[1];
  EXPECT_TRUE(ends(lines[1 + 3], ",1,0,,searching")) << lines[4];
  EXPECT_TRUE(ends(lines[1 + 6], ",1,1,ball_a,tracking")) << lines[7];
  EXPECT_TRUE(ends(lines[1 + 12], ",1,0,,coasting")) << lines[13];
  EXPECT_TRUE(ends(lines[1 + 15], ",1,1,ball_b,tracking")) << lines[16];
  EXPECT_EQ(lines[1 + 10].rfind("1.000000,10,", 0), 0u) << lines[11];
}

// A box's orientation is scored modulo its 90-degree turns about its own vertical axis: a yaw
// 3 degrees off, or 93, or -87, is 3 degrees; a pose without one, or of a ball, is no sample.
TEST(RunMetrics, ABoxsOrientationErrorIsTheAngleModuloItsQuarterTurns) {
  RunMetrics m("green_box", 0.0);
  const double truth_yaw = 0.4;
  const double deg = M_PI / 180;
  const std::vector<double> estimates = {truth_yaw + 3 * deg, truth_yaw + 93 * deg,
                                         truth_yaw - 87 * deg, truth_yaw - 3 * deg};
  for (int64_t seq = 0; seq < 6; ++seq) {
    ptzstereo::sim_truth_t t = syn::truth(seq, {{"box", "green_box", {0.1, 0.2, 2}}});
    t.objects[0].shape = "box";
    t.objects[0].orientation_wxyz[0] = std::cos(truth_yaw / 2);
    t.objects[0].orientation_wxyz[2] = std::sin(truth_yaw / 2);
    m.onTruth(t);
    ptzstereo::object_pose_t p = syn::pose(seq, "green_box", {0.1, 0.2, 2});
    auto& o = p.objects[1];
    if (seq < 4) {
      o.has_orientation = true;
      o.orientation_wxyz[0] = std::cos(estimates[static_cast<size_t>(seq)] / 2);
      o.orientation_wxyz[2] = std::sin(estimates[static_cast<size_t>(seq)] / 2);
    } else if (seq == 4) {
      o.has_orientation = false;  // not estimated
    } else {
      o.has_orientation = true;  // a quaternion of zeros is no orientation
    }
    m.onPose(p);
  }
  const auto s = m.summary();
  EXPECT_EQ(s.orientation_samples, 4);
  EXPECT_NEAR(s.orientation_error_rms_deg, 3.0, 1e-9);
  EXPECT_NE(s.toJson().find("\"orientation_samples\": 4"), std::string::npos) << s.toJson();

  RunMetrics ball("red_ball", 0.0);
  ball.onTruth(syn::truth(0, {kBall}));
  ptzstereo::object_pose_t p = syn::pose(0, "red_ball", kBall.position_m);
  p.objects[1].has_orientation = true;
  p.objects[1].orientation_wxyz[0] = 1;
  ball.onPose(p);
  EXPECT_EQ(ball.summary().orientation_samples, 0);
  EXPECT_NE(ball.summary().toJson().find("\"orientation_error_rms_deg\": null"), std::string::npos);
}

// A tagged box tells all its faces apart: a quarter turn off is 90 degrees, not 0.
TEST(RunMetrics, ATaggedBoxsOrientationErrorIsTheWholeAngle) {
  RunMetrics m("tool", 0.0);
  const double deg = M_PI / 180;
  const double errors_deg[2] = {90, 2};
  for (int64_t seq = 0; seq < 2; ++seq) {
    ptzstereo::sim_truth_t t = syn::truth(seq, {{"tool", "tool", {0.1, 0.2, 2}}});
    t.objects[0].shape = "tagged_box";
    t.objects[0].orientation_wxyz[0] = 1;
    m.onTruth(t);
    ptzstereo::object_pose_t p = syn::pose(seq, "tool", {0.1, 0.2, 2});
    auto& o = p.objects[1];
    o.has_orientation = true;
    // About its vertical axis: a plain box's quarter turn would be no error.
    o.orientation_wxyz[0] = std::cos(errors_deg[seq] * deg / 2);
    o.orientation_wxyz[2] = std::sin(errors_deg[seq] * deg / 2);
    m.onPose(p);
  }
  EXPECT_EQ(m.summary().orientation_samples, 2);
  EXPECT_NEAR(m.summary().orientation_error_rms_deg, std::sqrt((90.0 * 90 + 2 * 2) / 2), 1e-9);
}

TEST(RunMetrics, FramesTheSimulatorCouldNotSendCountAsLost) {
  RunMetrics m("red_ball", 0.0);
  for (int64_t seq = 0; seq < 20; ++seq) {
    m.onTruth(syn::truth(seq, {kBall}));
    m.onPose(syn::pose(seq, "red_ball", kBall.position_m));
  }
  // 20 sent and answered; 10 more made while its link was down, refused by LCM.
  ptzstereo::process_status_t status{};
  status.process = "ptz-sim";
  status.counters = {{"frames_published", 20}, {"STEREO_FRAME.publish_failures", 10}};
  status.num_counters = 2;
  m.onStatus(status);
  const auto s = m.summary();
  EXPECT_EQ(s.frames_published, 20);
  EXPECT_EQ(s.frames_not_published, 10);
  EXPECT_EQ(s.frames_without_pose, 10);
  EXPECT_NEAR(s.target_lost_s, 1.0, 1e-9);
  EXPECT_NE(s.toJson().find("\"frames_not_published\": 10,"), std::string::npos) << s.toJson();
}

// Where a channel fell silent and for how long (a link down between hosts), and what each process
// said it sent and received.
TEST(LogSummary, SilencesAndEachProcesssChannelsAreListed) {
  const std::string log = tempPath("silent.lcmlog");
  {
    syn::LogWriter w(log);
    for (int64_t seq = 0; seq < 30; ++seq) {
      w.put("SIM_TRUTH", syn::truth(seq, {kBall}));
      if (seq < 10 || seq >= 25) w.put("OBJECT_TRACKS", syn::tracks(seq, 1, 1));
    }
    ptzstereo::process_status_t status{};
    status.utime = syn::utimeOf(29);
    status.process = "ptz-detect";
    status.channels.push_back(
        {"OBJECT_TRACKS", ptzstereo::channel_status_t::DIRECTION_OUT, 30.0, 28, 0, 1.0, 2.0});
    status.channels.push_back(
        {"STEREO_FRAME", ptzstereo::channel_status_t::DIRECTION_IN, 30.0, 30, 3, 1.0, 2.0});
    status.num_channels = 2;
    w.put("PROCESS_STATUS_PTZ_DETECT", status);
  }
  const auto r = ptz::test::runProgram({PTZ_LOG_SUMMARY_BIN, "--log", log, "--gaps-over-s", "0.5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string silence = "silence OBJECT_TRACKS from " + std::to_string(syn::utimeOf(9)) +
                              " to " + std::to_string(syn::utimeOf(25)) + " (1.600 s)\n";
  EXPECT_NE(r.out.find(silence), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("silence SIM_TRUTH"), std::string::npos) << r.out;  // never 0.5 s silent
  EXPECT_NE(r.out.find("  out OBJECT_TRACKS                    28 messages, 0 dropped\n"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("  in  STEREO_FRAME                     30 messages, 3 dropped\n"),
            std::string::npos)
      << r.out;
  // The longest gap of each channel is in its row.
  std::istringstream rows(r.out);
  for (std::string line; std::getline(rows, line);) {
    if (line.rfind("OBJECT_TRACKS ", 0) == 0) {
      EXPECT_NE(line.find(" 1.600"), std::string::npos) << line;
    }
    if (line.rfind("SIM_TRUTH ", 0) == 0) {
      EXPECT_NE(line.find(" 0.100"), std::string::npos) << line;
    }
  }
}
