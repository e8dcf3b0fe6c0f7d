// ptz-calibrate --source lcm as a process: STEREO_FRAMEs of a board at random poses (rendered by
// the simulator's renderer in this test) in, a rig file out; and a stop before enough views.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <random>

#include "common/transport/transport.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/board_views.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"

namespace {

using ptz::test::ChildProcess;

std::vector<ptzstereo::stereo_frame_t> boardFrames(const ptz::StereoRig& rig, std::mt19937& rng,
                                                   int count) {
  ptz::test::BoardScene sim;
  const std::vector<ptz::CameraView> views = {rig.view(ptz::Side::kLeft, {}),
                                              rig.view(ptz::Side::kRight, {})};
  std::vector<ptzstereo::stereo_frame_t> frames;
  for (int i = 0; i < count; ++i) {
    EXPECT_TRUE(
        ptz::test::placeBoard(rng, views, {0, 0, 1.3}, {0.35, 0.25, 0.3}, 0.7, &sim.chessboard()));
    ptzstereo::stereo_frame_t m{};
    m.seq = i;
    m.left = ptz::encodeImage(sim.render(views[0]), ptzstereo::image_t::ENCODING_JPEG, 95);
    m.right = ptz::encodeImage(sim.render(views[1]), ptzstereo::image_t::ENCODING_JPEG, 95);
    m.left.zoom = m.right.zoom = 1;
    frames.push_back(m);
  }
  return frames;
}

TEST(CalibrateLive, CalibratesFromStereoFramesAndStopsAtTheTargetCount) {
  std::mt19937 rng(11);
  const ptz::StereoRig truth = ptz::test::randomRig(rng);
  const auto frames = boardFrames(truth, rng, 24);
  const std::string output = std::string(::testing::TempDir()) + "/ptz_calibrate_live_rig.yaml";
  std::remove(output.c_str());
  lcm::LCM lcm(ptz::test::kTestUrl);
  ASSERT_TRUE(lcm.good());
  ChildProcess tool({PTZ_CALIBRATE_BIN, "--source", "lcm", "--lcm-url", ptz::test::kTestUrl,
                     "--square-m", "0.05", "--target-views", "12", "--output", output});
  ASSERT_TRUE(tool.started());
  // The frames over and over (a queue of one drops what the tool has no time for) until it
  // has its views and exits.
  int exit_code = -1;
  for (size_t i = 0; exit_code < 0 && i < 3000; ++i) {
    auto frame = frames[i % frames.size()];
    frame.utime = ptz::wallUtime();
    lcm.publish(ptz::channels::kStereoFrame, &frame);
    exit_code = tool.wait(std::chrono::milliseconds(100));
  }
  ASSERT_EQ(exit_code, 0);
  const ptz::StereoRig rig = ptz::StereoRig::load(output);
  EXPECT_LT(std::abs(rig.baselineM() - truth.baselineM()) / truth.baselineM(), 0.005)
      << rig.baselineM() << " vs " << truth.baselineM();
  cv::FileStorage fs(output, cv::FileStorage::READ);
  EXPECT_EQ(fs["calibration"]["views"].size(), 12u);
}

// Frames with the cameras panned are not used (the stereo calibration holds at home); stopped
// with no views kept, the tool says so and fails.
TEST(CalibrateLive, IgnoresFramesAwayFromHomeAndFailsWhenStoppedWithTooFewViews) {
  std::mt19937 rng(12);
  auto frames = boardFrames(ptz::StereoRig::makeDefault(), rng, 4);
  for (auto& f : frames) f.left.pan_rad = 0.1;
  ChildProcess tool({PTZ_CALIBRATE_BIN, "--source", "lcm", "--lcm-url", ptz::test::kTestUrl,
                     "--status-period-s", "0.2", "--output",
                     std::string(::testing::TempDir()) + "/ptz_calibrate_none.yaml"});
  ASSERT_TRUE(tool.started());
  lcm::LCM lcm(ptz::test::kTestUrl);
  std::map<std::string, int64_t> counters;
  lcm.subscribeFunction(
      "PROCESS_STATUS_PTZ_CALIBRATE",
      +[](const lcm::ReceiveBuffer* rbuf, const std::string&, std::map<std::string, int64_t>* out) {
        ptzstereo::process_status_t m;
        if (m.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) return;
        for (const auto& c : m.counters) (*out)[c.name] = c.value;
      },
      &counters);
  for (size_t i = 0; counters["dropped_not_at_home"] < 3 && i < 300; ++i) {
    auto frame = frames[i % frames.size()];
    frame.utime = ptz::wallUtime();
    lcm.publish(ptz::channels::kStereoFrame, &frame);
    lcm.handleTimeout(100);
  }
  EXPECT_GE(counters["dropped_not_at_home"], 3);
  EXPECT_EQ(counters["frames_kept"], 0);
  EXPECT_EQ(tool.stop(), 2);
}

}  // namespace
