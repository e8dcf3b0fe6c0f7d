// ptz-camera playing a stereo pair of video files recorded here from the simulator's renderer
// (MJPG in .avi, with timestamps files), each frame's number drawn into its corner as big blocks:
// the right stream 8 ms late (tolerance 12 ms) with known frames dropped on both sides, stamped
// from PTZ_STATE messages the test publishes; then 18 ms late, where nothing may pair and the
// status must say so; and a reader blocked in its driver at exit.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

#include "common/transport/transport.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "sim/render/renderer.hpp"
#include "support/child_process.hpp"
#include "support/hardware/camera_recording.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;
using ptz::test::CameraListener;
using ptz::test::ChildProcess;
using ptz::test::readCode;
using ptz::test::TempDir;

namespace {

constexpr int kFrames = 60;
constexpr int64_t kPeriodUs = 40'000;  // recorded at 25 Hz

const std::array<std::vector<cv::Mat>, 2>& recording() {
  static const auto frames = ptz::test::renderCodedPair(kFrames, kPeriodUs * 1e-6);
  return frames;
}

// Writes the frames of one side (without the dropped ones) to video_path (MJPG) and their times
// (first + k * period + delay) beside it, one per line in microseconds.
void record(int side, const std::string& video_path, const std::string& timestamps_path,
            int64_t first_utime, int64_t delay_us, const std::set<int>& dropped) {
  cv::VideoWriter w(video_path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0,
                    cv::Size(640, 480));
  ASSERT_TRUE(w.isOpened()) << video_path;
  w.set(cv::VIDEOWRITER_PROP_QUALITY, 95);
  FILE* ts = std::fopen(timestamps_path.c_str(), "w");
  ASSERT_NE(ts, nullptr);
  for (int k = 0; k < kFrames; ++k) {
    if (dropped.count(k)) continue;
    w.write(recording()[static_cast<size_t>(side)][static_cast<size_t>(k)]);
    std::fprintf(ts, "%lld\n", static_cast<long long>(first_utime + k * kPeriodUs + delay_us));
  }
  std::fclose(ts);
}

// Known PTZ: linear in time from t0, the right camera mirrored in pan (linear interpolation of a
// linear function is exact).
ptzstereo::ptz_head_state_t head(int side, int64_t utime, int64_t t0) {
  const double t = static_cast<double>(utime - t0) * 1e-6;
  ptzstereo::ptz_head_state_t h{};
  h.pan_rad = (side == 0 ? 1 : -1) * (0.1 + 0.2 * t);
  h.tilt_rad = -0.05 + 0.1 * t;
  h.zoom = 1.0 + 0.5 * t;
  return h;
}

std::vector<std::string> cameraArgs(const TempDir& dir, const std::vector<std::string>& extra) {
  std::vector<std::string> args = {PTZ_CAMERA_BIN,
                                   "--lcm-url",
                                   ptz::test::kTestUrl,
                                   "--left-source",
                                   dir.path + "/left.avi",
                                   "--right-source",
                                   dir.path + "/right.avi",
                                   "--pair-tolerance-s",
                                   "0.012",
                                   "--status-period-s",
                                   "0.1",
                                   "--max-rate-hz",
                                   "0"};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

}  // namespace

TEST(CameraProcess, PlaysARecordedPairPairingByTimeAndStampingThePtzOfEachImage) {
  TempDir dir;
  ASSERT_EQ(::mkdir((dir.path + "/stage").c_str(), 0755), 0);
  const int64_t t0 = ptz::wallUtime() / 1000 * 1000;
  const std::set<int> drop_left = {33}, drop_right = {7, 20, 21};
  record(0, dir.path + "/stage/left.avi", dir.path + "/left.avi.timestamps", t0, 0, drop_left);
  record(1, dir.path + "/stage/right.avi", dir.path + "/right.avi.timestamps", t0, 8'000,
         drop_right);
  lcm::LCM lcm(ptz::test::kTestUrl);
  CameraListener l;
  lcm.subscribe("STEREO_FRAME", &CameraListener::onFrame, &l);
  lcm.subscribe("PROCESS_STATUS_PTZ_CAMERA", &CameraListener::onStatus, &l);
  // The videos are not there yet: ptz-camera retries them while the test publishes PTZ_STATE
  // covering the whole recording, so that every frame finds its states.
  ChildProcess camera(
      cameraArgs(dir, {"--encoding", "jpeg", "--jpeg-quality", "95", "--retry-initial-s", "0.2",
                       "--retry-max-s", "0.2", "--ptz-history-s", "60"}));
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.message.find("is missing or unreadable") != std::string::npos; }, 10s))
      << l.message;
  EXPECT_EQ(l.state, ptzstereo::process_status_t::STATE_ERROR);
  EXPECT_NE(l.message.find("left source " + dir.path + "/left.avi: cannot open: video file"),
            std::string::npos)
      << l.message;
  int64_t published = 0;
  for (int64_t t = t0 - 500'000; t <= t0 + kFrames * kPeriodUs + 500'000; t += 20'000) {
    ptzstereo::ptz_state_t s{};
    s.utime = t;
    s.publish_utime = ptz::wallUtime();
    s.left = head(0, t, t0);
    s.right = head(1, t, t0);
    lcm.publish("PTZ_STATE", &s);
    ++published;
  }
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.states_in == published; }, 10s))
      << l.states_in << " of " << published << " states arrived";
  for (const char* name : {"left.avi", "right.avi"}) {
    ASSERT_EQ(std::rename((dir.path + "/stage/" + name).c_str(), (dir.path + "/" + name).c_str()),
              0);
  }
  ptz::test::handleUntil(
      lcm, [&] { return camera.wait(0ms) >= 0; }, 30s);
  ptz::test::drain(lcm, 300ms);
  ASSERT_EQ(camera.wait(0ms), 0) << "ptz-camera exits 0 when both files ended";

  const int expected_pairs = kFrames - 4;  // 7, 20, 21 and 33 lost their partners
  EXPECT_EQ(l.counters["pairs"], expected_pairs);
  EXPECT_EQ(l.counters["unmatched_left"], 3);
  EXPECT_EQ(l.counters["unmatched_right"], 1);
  EXPECT_EQ(l.counters["ptz_stale"], 0);
  EXPECT_EQ(l.counters["ended_left"], 1);
  EXPECT_EQ(l.counters["ended_right"], 1);
  EXPECT_GE(l.counters["reconnects_left"], 1);  // the missing file was retried
  ASSERT_EQ(static_cast<int>(l.frames.size()), expected_pairs);
  std::set<int> seen;
  double worst_diff = 0;
  for (size_t i = 0; i < l.frames.size(); ++i) {
    const auto& m = l.frames[i];
    EXPECT_EQ(m.seq, static_cast<int64_t>(i));
    cv::Mat left, right;
    std::string error;
    ASSERT_TRUE(ptz::decodeImage(m.left, &left, &error)) << error;
    ASSERT_TRUE(ptz::decodeImage(m.right, &right, &error)) << error;
    const auto [kl, side_l] = readCode(left);
    const auto [kr, side_r] = readCode(right);
    ASSERT_GE(kl, 0);
    EXPECT_EQ(kl, kr) << "pair " << i << ": left frame " << kl << ", right frame " << kr;
    EXPECT_EQ(side_l, 0);
    EXPECT_EQ(side_r, 1);
    seen.insert(kl);
    EXPECT_EQ(m.utime, t0 + kl * kPeriodUs);  // the pair's time is the left image's
    const auto hl = head(0, t0 + kl * kPeriodUs, t0);
    const auto hr = head(1, t0 + kl * kPeriodUs + 8'000, t0);  // the right one's own time
    EXPECT_NEAR(m.left.pan_rad, hl.pan_rad, 1e-9);
    EXPECT_NEAR(m.left.tilt_rad, hl.tilt_rad, 1e-9);
    EXPECT_NEAR(m.left.zoom, hl.zoom, 1e-9);
    EXPECT_NEAR(m.right.pan_rad, hr.pan_rad, 1e-9);
    EXPECT_NEAR(m.right.tilt_rad, hr.tilt_rad, 1e-9);
    EXPECT_NEAR(m.right.zoom, hr.zoom, 1e-9);
    // The images are the ones rendered for that instant (MJPG then JPEG: a few grey levels).
    cv::Mat diff;
    cv::absdiff(left, recording()[0][static_cast<size_t>(kl)], diff);
    worst_diff = std::max(worst_diff, cv::mean(diff)[0]);
    cv::absdiff(right, recording()[1][static_cast<size_t>(kl)], diff);
    worst_diff = std::max(worst_diff, cv::mean(diff)[0]);
  }
  EXPECT_EQ(seen.size(), static_cast<size_t>(expected_pairs));
  EXPECT_EQ(seen.count(7) + seen.count(20) + seen.count(21) + seen.count(33), 0u);
  EXPECT_LT(worst_diff, 4.0);
  std::printf(
      "pairs %zu, worst mean difference to the rendered image %.2f grey levels, "
      "pair wait p50 %.1f ms p99 %.1f ms\n",
      l.frames.size(), worst_diff, l.counters["pair_wait_us_p50"] / 1000.0,
      l.counters["pair_wait_us_p99"] / 1000.0);
}

TEST(CameraProcess, ARigWhoseSidesNeverPairSaysSoWithTheOffset) {
  TempDir dir;
  const int64_t t0 = ptz::wallUtime() / 1000 * 1000;
  record(0, dir.path + "/left.avi", dir.path + "/left.avi.timestamps", t0, 0, {});
  record(1, dir.path + "/right.avi", dir.path + "/right.avi.timestamps", t0, 18'000, {});
  lcm::LCM lcm(ptz::test::kTestUrl);
  CameraListener l;
  lcm.subscribe("STEREO_FRAME", &CameraListener::onFrame, &l);
  lcm.subscribe("PROCESS_STATUS_PTZ_CAMERA", &CameraListener::onStatus, &l);
  const auto start = std::chrono::steady_clock::now();
  ChildProcess camera(cameraArgs(dir, {"--no-pair-warn-s", "1.0"}));
  const std::string kNoPair = "no stereo pair in ";
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.message.find(kNoPair) != std::string::npos; }, 20s))
      << l.message;
  const double after_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(l.state, ptzstereo::process_status_t::STATE_ERROR);
  EXPECT_NE(l.message.find(": right is 0.018 s behind left (tolerance 0.012 s); check the clocks "
                           "or raise pair_tolerance_s"),
            std::string::npos)
      << l.message;
  // When: no_pair_warn_s after both sides began to deliver, by the process's own clock (the
  // message says how long nothing paired): not before, and within a status period (0.1 s) and
  // what a busy machine delays the loop. The start-up (seconds on a busy machine) is not in it.
  const double quiet_s = std::stod(l.message.substr(l.message.find(kNoPair) + kNoPair.size()));
  EXPECT_GE(quiet_s, 1.0) << l.message;
  EXPECT_LE(quiet_s, 1.0 + 0.5) << l.message;
  ptz::test::handleUntil(
      lcm, [&] { return camera.wait(0ms) >= 0; }, 30s);
  ptz::test::drain(lcm, 300ms);
  ASSERT_EQ(camera.wait(0ms), 0);
  EXPECT_TRUE(l.frames.empty());
  EXPECT_EQ(l.counters["pairs"], 0);
  EXPECT_EQ(l.counters["unmatched_left"], kFrames);
  EXPECT_EQ(l.counters["unmatched_right"], kFrames);
  std::printf("no-pair ERROR after %.1f s without a pair, %.2f s after the start\n", quiet_s,
              after_s);
}

TEST(CameraProcess, AReaderStillBlockedInItsDriverAtExitIsReportedAndSkipsTheStaticDestructors) {
  // The right source is a GStreamer pipeline reading a FIFO nobody writes: its reader blocks
  // in open(2) for good, as one does in a stalled RTSP stream. ptz-camera is stopped while that
  // connection is still current (open_timeout_s far away), so the reader is only abandoned when
  // the sources are closed at exit; the check must come after that.
  TempDir dir;
  const std::string fifo = dir.path + "/stalled.fifo", log = dir.path + "/camera.err";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  lcm::LCM lcm(ptz::test::kTestUrl);
  CameraListener l;
  lcm.subscribe("PROCESS_STATUS_PTZ_CAMERA", &CameraListener::onStatus, &l);
  // Through sh only to catch its stderr; exec keeps the pid, so SIGTERM reaches ptz-camera.
  ChildProcess camera({"/bin/sh", "-c", "log=$1; shift; exec \"$@\" 2>\"$log\"", "sh", log,
                       PTZ_CAMERA_BIN, "--lcm-url", ptz::test::kTestUrl, "--left-source",
                       "videotestsrc is-live=true ! video/x-raw,width=64,height=48,framerate=25/1 "
                       "! videoconvert ! appsink",
                       "--right-source",
                       "filesrc location=" + fifo + " ! decodebin ! videoconvert ! appsink",
                       "--open-timeout-s", "60", "--status-period-s", "0.1"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["frames_left"] >= 5; }, 20s))
      << "status: " << l.message;
  EXPECT_EQ(l.counters["frames_right"], 0);
  EXPECT_EQ(l.counters["reconnects_right"], 0);
  EXPECT_EQ(l.counters["abandoned_readers"], 0);
  EXPECT_EQ(camera.stop(), 0);
  std::ifstream in(log);
  const std::string err((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(err.find("ptz-camera: 1 reader(s) still blocked in a driver at exit"),
            std::string::npos)
      << "stderr: " << err;
}

TEST(CameraProcess, WithATriggerLineCamerasThatDoNotFollowItAreNamed) {
  // Two free-running test cameras at 23 Hz, and trigger pulses at 30 Hz on a simulated chip:
  // their frames sweep past the pulses, most far from any, so both sides are named and the
  // status is ERROR, while the pulses go on.
  lcm::LCM lcm(ptz::test::kTestUrl);
  CameraListener l;
  lcm.subscribe("PROCESS_STATUS_PTZ_CAMERA", &CameraListener::onStatus, &l);
  const std::string free_running =
      "videotestsrc is-live=true ! video/x-raw,width=64,height=48,framerate=23/1 ! videoconvert "
      "! appsink";
  ChildProcess camera({PTZ_CAMERA_BIN, "--lcm-url", ptz::test::kTestUrl, "--left-source",
                       free_running, "--right-source", free_running, "--trigger-chip", "sim",
                       "--trigger-line", "4", "--trigger-rate-hz", "30", "--trigger-window-s",
                       "0.003", "--no-pair-warn-s", "1.0", "--status-period-s", "0.1"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] {
        return l.message.find("left camera") != std::string::npos &&
               l.message.find("right camera") != std::string::npos &&
               l.counters["frames_left"] >= 20 && l.counters["frames_right"] >= 20;
      },
      20s))
      << l.message;
  EXPECT_EQ(l.state, ptzstereo::process_status_t::STATE_ERROR);
  EXPECT_NE(l.message.find(" none within 3.0 ms, median distance "), std::string::npos)
      << l.message;
  EXPECT_NE(l.message.find("is it in external-trigger mode"), std::string::npos) << l.message;
  // A 23 Hz camera lies within 3 ms of a 30 Hz pulse for about 6/33 of its frames.
  for (const char* side : {"left", "right"}) {
    const int64_t matched = l.counters[std::string("trigger_matched_") + side];
    const int64_t unmatched = l.counters[std::string("trigger_unmatched_") + side];
    EXPECT_LT(matched, unmatched) << side;
  }
  const int64_t pulses = l.counters["trigger_pulses"];
  EXPECT_GT(pulses, 0);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["trigger_pulses"] >= pulses + 15; }, 10s))
      << "the pulses stopped at " << l.counters["trigger_pulses"];
  EXPECT_EQ(camera.stop(), 0);
  std::printf("trigger: %lld pulses, %lld missed periods, edges late p50 %lld us p99 %lld us; %s\n",
              static_cast<long long>(l.counters["trigger_pulses"]),
              static_cast<long long>(l.counters["trigger_missed_periods"]),
              static_cast<long long>(l.counters["trigger_late_us_p50"]),
              static_cast<long long>(l.counters["trigger_late_us_p99"]), l.message.c_str());
}

TEST(CameraProcess, ATriggerChipThatDoesNotExistExitsTwoNamingIt) {
  const std::string command =
      std::string("timeout 20 ") + PTZ_CAMERA_BIN +
      " --lcm-url memq:// --left-source 0 --right-source 1"
      " --trigger-chip /dev/gpiochip99 --trigger-line 17 2>&1; echo exit=$?";
  const std::string out = ptz::test::runShell(command);
  EXPECT_NE(out.find("parameter 'trigger_chip': cannot open GPIO chip '/dev/gpiochip99'"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("exit=2"), std::string::npos) << out;
}
