// ptz-report on the committed 2 s run: every plot, and a summary whose numbers match what this
// test computes from the log on its own (OpenCV's projectPoints for the centring); broken,
// empty and unrelated logs; a made-up run's track ids and controller states over time.
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>

#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "tools/logs/synthetic_run.hpp"
#include "tools/report/report.hpp"

namespace {

const std::string kFixture = PTZ_SOURCE_DIR "/test/fixtures/closed_loop_2s.lcmlog";

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + name;
}

std::string readAll(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// The true target's pixel offset from the image centre, by OpenCV from the camera model alone.
double offsetPx(const ptzstereo::camera_model_t& cam, const double p_head[3]) {
  cv::Matx33d R_head_camera(cam.rotation_head_camera);
  const cv::Matx33d R = R_head_camera.t();  // head -> camera
  const cv::Vec3d c(cam.position_head_m[0], cam.position_head_m[1], cam.position_head_m[2]);
  const cv::Vec3d t = -(R * c);
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  const cv::Matx33d K(cam.fx_px, 0, cam.cx_px, 0, cam.fy_px, cam.cy_px, 0, 0, 1);
  std::vector<double> dist(cam.distortion, cam.distortion + 5);
  std::vector<cv::Point2d> px;
  cv::projectPoints(std::vector<cv::Point3d>{{p_head[0], p_head[1], p_head[2]}}, rvec, t, K, dist,
                    px);
  return std::hypot(px[0].x - (cam.width - 1) / 2.0, px[0].y - (cam.height - 1) / 2.0);
}

// A number of summary.json (OpenCV's JSON reader refuses null).
double jsonNumber(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return NAN;
  return std::strtod(json.c_str() + at + key.size() + 4, nullptr);
}

int runReport(const std::string& args, std::string* output) {
  // One file per test: ctest runs the tests of this suite side by side.
  const std::string out = tempPath(
      std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + ".output.txt");
  const int status = std::system((PTZ_REPORT_BIN " " + args + " > " + out + " 2>&1").c_str());
  *output = readAll(out);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST(Report, EveryPlotAndASummaryThatMatchesTheLog) {
  const std::string dir = tempPath("fixture.report");
  std::string output;
  ASSERT_EQ(runReport(kFixture + " --out " + dir + " --settle-s 0.5", &output), 0) << output;
  for (const char* png : {"ptz.png", "centring.png", "position.png", "delay.png", "rates.png"}) {
    const cv::Mat image = cv::imread(dir + "/" + png);
    EXPECT_EQ(image.cols, 1000) << png;
    EXPECT_EQ(image.rows, 750) << png;
    EXPECT_NE(readAll(dir + "/report.md").find(std::string("](") + png + ")"), std::string::npos)
        << png << " is not shown in report.md";
  }
  // The numbers, from the log by this test (a pose may be logged before its truth).
  int64_t frames = 0, poses = 0, without_target = 0;
  std::map<int64_t, ptzstereo::sim_truth_t> truth;
  std::vector<ptzstereo::object_pose_t> targeted;
  std::vector<double> errors_m, centring_px;
  int64_t first_utime = -1;
  lcm::LogFile log(kFixture, "r");
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == "STEREO_FRAME") ++frames;
    if (ev->channel == "SIM_TRUTH") {
      ptzstereo::sim_truth_t t;
      ASSERT_GE(t.decode(ev->data, 0, ev->datalen), 0);
      truth[t.frame_seq] = t;
      if (first_utime < 0) first_utime = t.utime;
      if (t.utime - first_utime >= 500000) {
        centring_px.push_back(offsetPx(t.left_camera, t.objects[0].position_m));
        centring_px.push_back(offsetPx(t.right_camera, t.objects[0].position_m));
      }
    }
    if (ev->channel == "OBJECT_POSE") {
      ptzstereo::object_pose_t p;
      ASSERT_GE(p.decode(ev->data, 0, ev->datalen), 0);
      ++poses;
      if (p.target_index < 0) {
        ++without_target;
        continue;
      }
      targeted.push_back(p);
    }
  }
  for (const auto& p : targeted) {
    const auto& o = p.objects[static_cast<size_t>(p.target_index)];
    ASSERT_EQ(truth.count(p.frame_seq), 1u) << "frame " << p.frame_seq;
    const auto& t = truth.at(p.frame_seq).objects[0];
    errors_m.push_back(std::hypot(o.position_m[0] - t.position_m[0],
                                  o.position_m[1] - t.position_m[1],
                                  o.position_m[2] - t.position_m[2]));
  }
  auto rms = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return std::sqrt(s / v.size());
  };
  ASSERT_EQ(truth.begin()->second.objects[0].class_name, "red_ball");
  const std::string summary = readAll(dir + "/summary.json");
  EXPECT_EQ(jsonNumber(summary, "frames_published"), frames);
  EXPECT_EQ(jsonNumber(summary, "frames_processed"), poses);
  EXPECT_EQ(jsonNumber(summary, "poses_without_target"), without_target);
  EXPECT_NEAR(jsonNumber(summary, "position_error_rms_m"), rms(errors_m), 1e-5);
  EXPECT_NEAR(jsonNumber(summary, "centering_rms_px"), rms(centring_px), 1e-3);
  // Every setpoint is in the delay histogram's data.
  const std::string delays = readAll(dir + "/delay.csv");
  EXPECT_EQ(std::count(delays.begin(), delays.end(), '\n') - 1, poses);
}

TEST(Report, ATruncatedLogIsReportedAsFarAsItGoesAndSaysWhere) {
  const std::string bytes = readAll(kFixture);
  const std::string cut = tempPath("truncated.lcmlog");
  const size_t keep = bytes.size() * 6 / 10;
  std::ofstream(cut, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(keep));
  std::string output;
  ASSERT_EQ(runReport(cut + " --out " + tempPath("truncated.report"), &output), 0) << output;
  EXPECT_NE(output.find("partial or unreadable event (cut off) at byte"), std::string::npos)
      << output;
  EXPECT_NE(readAll(tempPath("truncated.report/report.md")).find("The log is broken"),
            std::string::npos);
  EXPECT_FALSE(cv::imread(tempPath("truncated.report/ptz.png")).empty());
}

TEST(Report, GarbageInTheMiddleIsSkippedAndLocated) {
  std::string bytes = readAll(kFixture);
  // From the first event header after the middle (LCM's sync word), so the garbage breaks an
  // event whatever the sizes of the events around the middle.
  const size_t at = bytes.find(std::string("\xED\xA1\xDA\x01", 4), bytes.size() / 2);
  ASSERT_NE(at, std::string::npos);
  ASSERT_LT(at + 5000, bytes.size());
  for (size_t i = at; i < at + 5000; ++i) bytes[i] = static_cast<char>(i * 7919 % 251);
  const std::string path = tempPath("corrupt.lcmlog");
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ptz::tools::LogReader reader(path);
  const ptz::tools::ReportData d = ptz::tools::collectReport(reader, {});
  ASSERT_FALSE(reader.breaks().empty());
  const auto& b = reader.breaks().front();
  EXPECT_LE(b.offset, static_cast<int64_t>(at));  // the broken event starts at or before it
  EXPECT_GE(b.offset + b.bytes, static_cast<int64_t>(at + 5000));
  EXPECT_GT(d.states.size(), 100u);  // what follows is read
}

TEST(Report, AnEmptyLogOrOneWithoutTheNeededChannelsIsRefused) {
  const std::string empty = tempPath("empty.lcmlog");
  std::ofstream(empty).close();
  std::string output;
  EXPECT_EQ(runReport(empty, &output), 5);
  EXPECT_EQ(output, "ptz-report: log '" + empty + "' is empty (0 bytes)\n");

  const std::string other = tempPath("status_only.lcmlog");
  {
    lcm::LogFile log(other, "w");
    ptzstereo::process_status_t s{};
    s.process = "someone";
    std::vector<uint8_t> buf(static_cast<size_t>(s.getEncodedSize()));
    s.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent ev{};
    ev.channel = "PROCESS_STATUS_SOMEONE";
    ev.datalen = static_cast<int32_t>(buf.size());
    ev.data = buf.data();
    log.writeEvent(&ev);
  }
  EXPECT_EQ(runReport(other + " --out " + tempPath("status_only.report"), &output), 7);
  EXPECT_EQ(output, "ptz-report: log '" + other +
                        "' lacks the channels needed: none of STEREO_FRAME, PTZ_STATE, "
                        "PTZ_SETPOINT, SIM_TRUTH; it has PROCESS_STATUS_SOMEONE (1)\n");
  EXPECT_FALSE(std::ifstream(tempPath("status_only.report/report.md")).good());  // no folder
  EXPECT_EQ(runReport("/nonexistent/run.lcmlog", &output), 4);
  EXPECT_EQ(output, "ptz-report: log '/nonexistent/run.lcmlog': No such file or directory\n");
  EXPECT_EQ(runReport(kFixture + " --settle-s -5", &output), 2);
  EXPECT_EQ(output, "ptz-report: flag --settle-s: parameter 'settle_s' must be >= 0, got '-5'\n");
}

TEST(Report, TrackIdsAndControllerStateOverTimeAndTheRunsNumbersOfAKnownRun) {
  namespace syn = ptz::test::synthetic;
  using K = syn::KnownRun;
  const std::string log = tempPath("known.lcmlog"), dir = tempPath("known.report");
  syn::writeKnownRun(log);
  ptz::tools::LogReader reader(log);
  ptz::tools::ReportOptions options;
  options.settle_s = 0;
  const ptz::tools::ReportData d = ptz::tools::collectReport(reader, options);
  ASSERT_EQ(d.target_tracks.size(), 18u);  // frames 2-19
  EXPECT_NEAR(d.target_tracks[0].t_s, 0.2, 1e-9);
  EXPECT_EQ(d.target_tracks[0].target_id, -1);
  EXPECT_EQ(d.target_tracks[5].target_id, 1);   // frame 7
  EXPECT_EQ(d.target_tracks[14].target_id, 2);  // frame 16
  EXPECT_EQ(d.target_tracks[14].tracks, 2);
  // Every track of every message: none in frames 2-4, two in frames 5-19.
  ASSERT_EQ(d.track_points.size(), 15u * 2);
  EXPECT_NEAR(d.track_points[0].t_s, 0.5, 1e-9);
  EXPECT_EQ(d.track_points.back().id, 2);
  EXPECT_EQ(d.track_points.back().state, ptzstereo::object_track_t::STATE_CONFIRMED);
  ASSERT_EQ(d.control.size(), 18u);
  EXPECT_EQ(d.control[0].state, ptzstereo::control_state_t::STATE_SEARCHING);
  EXPECT_EQ(d.control[10].state, ptzstereo::control_state_t::STATE_COASTING);  // frame 12
  // The 3D truth of each position is the object tracked: ball_b once it is the target.
  ASSERT_EQ(d.positions.size(), static_cast<size_t>(K::kOnA + K::kOnB));
  EXPECT_EQ(d.positions.back().truth_m[0], 0.5);
  EXPECT_EQ(d.positions.front().truth_m[0], 0.0);
  EXPECT_EQ(d.summary.target_switches, K::kSwitches);
  EXPECT_NEAR(d.summary.search_time_s, K::kSearchS, 1e-9);
  EXPECT_NEAR(d.summary.coast_time_s, K::kCoastS, 1e-9);
  EXPECT_NEAR(d.summary.time_to_acquire_s, K::kAcquireS, 1e-9);
  EXPECT_NEAR(d.summary.target_lost_s, K::kLostS, 1e-9);
  EXPECT_EQ(d.summary.frames_without_pose, K::kWithoutPose);

  std::string output;
  ASSERT_EQ(runReport(log + " --out " + dir + " --settle-s 0", &output), 0) << output;
  const cv::Mat image = cv::imread(dir + "/tracks.png");
  EXPECT_EQ(image.cols, 1000);
  EXPECT_EQ(image.rows, 750);
  EXPECT_NE(readAll(dir + "/report.md").find("](tracks.png)"), std::string::npos);
  const std::string control = readAll(dir + "/control_state.csv");
  EXPECT_EQ(control.rfind("t_s,state,target_id\n0.2,2,-1\n", 0), 0u) << control;
  const std::string target = readAll(dir + "/target.csv");
  EXPECT_NE(target.find("\n1.6,2,2\n"), std::string::npos) << target;
  const std::string points = readAll(dir + "/tracks.csv");
  EXPECT_EQ(points.rfind("t_s,track_id,state\n0.5,1,1\n", 0), 0u) << points;
  const std::string summary = readAll(dir + "/summary.json");
  EXPECT_EQ(jsonNumber(summary, "target_switches"), K::kSwitches);
  EXPECT_NEAR(jsonNumber(summary, "search_time_s"), K::kSearchS, 1e-9);
}
