// ptz-camera against real RTSP servers on 127.0.0.1 (gst-rtsp-server, as IP PTZ cameras serve
// their video): two feeds recorded from the simulator's renderer, consumed through OpenCV's
// GStreamer backend, paired and published as STEREO_FRAME. Stopping the right server mid-stream
// must give an ERROR status naming the source, and its restart a reconnection after which the
// pairs come again.
#include <gtest/gtest.h>

#include <opencv2/videoio.hpp>

#include <algorithm>
#include <array>
#include <map>
#include <memory>

#include "common/transport/transport.hpp"
#include "support/child_process.hpp"
#include "support/hardware/camera_recording.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;
using ptz::test::CameraListener;
using ptz::test::ChildProcess;

namespace {

constexpr int kFrames = 250;  // 10 s at 25 Hz: longer than the test streams
constexpr double kPeriodS = 0.04;
const std::string kLeftUrl = "rtsp://127.0.0.1:8554/left";
const std::string kRightUrl = "rtsp://127.0.0.1:8555/right";

// The frames' top left quarter, their numbers included: a quarter of the decoding and encoding
// on the way, so that a busy machine does not leave ptz-camera behind its feeds.
const cv::Rect kCrop(0, 0, 320, 240);

void writeVideo(const std::vector<cv::Mat>& frames, const std::string& path) {
  cv::VideoWriter w(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 1.0 / kPeriodS,
                    kCrop.size());
  ASSERT_TRUE(w.isOpened()) << path;
  for (const auto& f : frames) w.write(f(kCrop).clone());
}

// An IP camera streams from a CPU of its own: the servers that stand in for them run at a high
// priority, so that a busy machine delays what ptz-camera does, not what the cameras send (a
// starved server sends its frames late and in bursts, which no receiver can pair by time).
// Without the right to raise it, nice says so and runs the server as it is.
std::unique_ptr<ChildProcess> server(const std::string& port, const std::string& mount,
                                     const std::string& file) {
  return std::make_unique<ChildProcess>(std::vector<std::string>{
      "/usr/bin/nice", "-n", "-15", PTZ_RTSP_SERVER_BIN, port, mount, file});
}

// What the pairs from `first` on say: every image a recorded frame of its own side, each
// side's frames in order and used once, and the left − right frame offsets. A side's frame
// number going back is a new connection (its server starts the file again): the offsets of
// each connection are counted apart.
struct PairCheck {
  std::vector<std::map<int, int>> offsets{1};  // per run of connections: offset -> pairs
  int unreadable = 0, repeated = 0, pairs = 0;
  std::array<int, 2> restarts{0, 0};  // left, right
  // The share of pairs within one frame of their connection's most common offset (the
  // tolerance is half a period, so an arrival jitter may shift a partner by one), and the most
  // common offset of the last connection.
  std::pair<double, int> consistency() const {
    int near = 0, mode = 0;
    for (const auto& run : offsets) {
      int best = 0;
      for (const auto& [o, n] : run) {
        if (n > best) best = n, mode = o;
      }
      for (const auto& [o, n] : run) near += std::abs(o - mode) <= 1 ? n : 0;
    }
    return {pairs ? static_cast<double>(near) / pairs : 0.0, mode};
  }
};

PairCheck checkPairs(const std::vector<ptzstereo::stereo_frame_t>& frames, size_t first) {
  PairCheck c;
  int last_l = -1, last_r = -1;
  for (size_t i = first; i < frames.size(); ++i) {
    cv::Mat left, right;
    std::string error;
    EXPECT_TRUE(ptz::decodeImage(frames[i].left, &left, &error)) << error;
    EXPECT_TRUE(ptz::decodeImage(frames[i].right, &right, &error)) << error;
    const auto [kl, side_l] = ptz::test::readCode(left);
    const auto [kr, side_r] = ptz::test::readCode(right);
    if (kl < 0 || kr < 0 || side_l != 0 || side_r != 1) {
      ++c.unreadable;
      continue;
    }
    if (kl == last_l || kr == last_r) ++c.repeated;
    if (kl < last_l || kr < last_r) {
      c.restarts[0] += kl < last_l;
      c.restarts[1] += kr < last_r;
      c.offsets.emplace_back();
    }
    last_l = kl;
    last_r = kr;
    ++c.offsets.back()[kl - kr];
    ++c.pairs;
  }
  return c;
}

}  // namespace

TEST(CameraRtsp, PairsTwoRtspFeedsAndReconnectsWhenAServerComesBack) {
  ptz::test::TempDir dir;
  {
    const auto rec = ptz::test::renderCodedPair(kFrames, kPeriodS);
    writeVideo(rec[0], dir.path + "/left.avi");
    writeVideo(rec[1], dir.path + "/right.avi");
  }
  auto left_server = server("8554", "left", dir.path + "/left.avi");
  auto right_server = server("8555", "right", dir.path + "/right.avi");
  lcm::LCM lcm(ptz::test::kTestUrl);
  CameraListener l;
  lcm.subscribe("STEREO_FRAME", &CameraListener::onFrame, &l);
  lcm.subscribe("PROCESS_STATUS_PTZ_CAMERA", &CameraListener::onStatus, &l);
  // Unsynchronised live feeds at 25 Hz: a partner is always within half a period.
  ChildProcess camera({PTZ_CAMERA_BIN,
                       "--lcm-url",
                       ptz::test::kTestUrl,
                       "--left-source",
                       kLeftUrl,
                       "--right-source",
                       kRightUrl,
                       "--pair-tolerance-s",
                       "0.02",
                       "--encoding",
                       "jpeg",
                       "--width",
                       "320",
                       "--height",
                       "240",
                       "--status-period-s",
                       "0.1",
                       "--retry-initial-s",
                       "0.2",
                       "--retry-max-s",
                       "0.4",
                       "--max-rate-hz",
                       "0"});

  // Streaming: pairs of frames recorded for the same instant, consistently.
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.frames.size() >= 40; }, 20s))
      << l.frames.size() << " pairs; status: " << l.message;
  // No PTZ_STATE in this test: the status may WARN about the stamping, never ERROR.
  EXPECT_NE(l.state, ptzstereo::process_status_t::STATE_ERROR) << l.message;
  const PairCheck before = checkPairs(l.frames, 0);
  EXPECT_EQ(before.unreadable, 0) << "images garbled or of the wrong side";
  EXPECT_EQ(before.repeated, 0) << "a frame published twice";
  // Out of order only as a new connection (a busy machine may starve a feed into one).
  EXPECT_LE(before.restarts[0], l.counters["reconnects_left"]);
  EXPECT_LE(before.restarts[1], l.counters["reconnects_right"]);
  const auto [share_before, offset_before] = before.consistency();
  EXPECT_GE(share_before, 0.95) << "pairs jump between partners";

  // The right camera goes away: an ERROR naming it, nothing published without it.
  right_server->stop();
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] {
        return l.state == ptzstereo::process_status_t::STATE_ERROR &&
               l.message.find("right source " + kRightUrl) != std::string::npos;
      },
      10s))
      << l.message;
  const std::string error_message = l.message;
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["reconnects_right"] >= 2; }, 10s))
      << "retries while the server is down: " << l.counters["reconnects_right"];
  const size_t pairs_while_down = l.frames.size();

  // It comes back: ptz-camera reconnects by itself and pairs again.
  right_server = server("8555", "right", dir.path + "/right.avi");
  const int64_t reconnects_right_down = l.counters["reconnects_right"];
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] {
        return l.frames.size() >= pairs_while_down + 40 &&
               l.state != ptzstereo::process_status_t::STATE_ERROR;
      },
      20s))
      << l.frames.size() - pairs_while_down << " pairs after the restart; status: " << l.message;
  const PairCheck after = checkPairs(l.frames, pairs_while_down);
  EXPECT_EQ(after.unreadable, 0);
  EXPECT_EQ(after.repeated, 0);
  EXPECT_LE(after.restarts[0], l.counters["reconnects_left"]);
  EXPECT_LE(after.restarts[1], l.counters["reconnects_right"] - reconnects_right_down);
  const auto [share_after, offset_after] = after.consistency();
  EXPECT_GE(share_after, 0.95) << "pairs jump between partners after the reconnection";
  EXPECT_EQ(camera.stop(), 0);
  left_server->stop();
  right_server->stop();
  std::printf(
      "RTSP: %zu pairs before the stop (%.0f %% within a frame of offset %d), error \"%s\", %lld "
      "reconnects of the right source, %zu pairs after (%.0f %% within a frame of offset %d), "
      "unmatched left %lld right %lld, pair wait p50 %.1f ms p99 %.1f ms\n",
      pairs_while_down, 100 * share_before, offset_before, error_message.c_str(),
      static_cast<long long>(l.counters["reconnects_right"]), l.frames.size() - pairs_while_down,
      100 * share_after, offset_after, static_cast<long long>(l.counters["unmatched_left"]),
      static_cast<long long>(l.counters["unmatched_right"]),
      l.counters["pair_wait_us_p50"] / 1000.0, l.counters["pair_wait_us_p99"] / 1000.0);
}
