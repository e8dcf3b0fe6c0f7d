// ptz-camera playing a 1080p JPEG recording rendered by the simulator (issue #18): every image
// published is the recorded file byte for byte (no decode, no re-encode), every pair in order
// with its recorded time; a folder with a file that does not decode and one cut short: the first
// skipped, counted and named, the second decoded and re-encoded, the rest passed through.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "support/child_process.hpp"
#include "support/hardware/camera_recording.hpp"
#include "support/lcm_wait.hpp"
#include "support/sim_recording.hpp"

using namespace std::chrono_literals;
using ptz::test::CameraListener;
using ptz::test::ChildProcess;
using ptz::test::TempDir;

namespace {

const std::string kScenario =
    std::string(PTZ_SOURCE_DIR) + "/test/scenarios/demo_figure_eight.yaml";

std::vector<uint8_t> fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string frameFile(const std::string& dir, const char* side, size_t k) {
  char name[32];
  std::snprintf(name, sizeof name, "/%06zu.jpg", k);
  return dir + "/" + side + name;
}

// ptz-camera playing dir at 1080p in JPEG (previews at 5 Hz) until both sides end; its frames,
// previews and last status.
void play(const std::string& dir, CameraListener* l,
          std::vector<ptzstereo::stereo_frame_t>* previews) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  lcm.subscribe("STEREO_FRAME", &CameraListener::onFrame, l);
  lcm.subscribe("PROCESS_STATUS_PTZ_CAMERA", &CameraListener::onStatus, l);
  lcm.subscribeFunction(
      "STEREO_PREVIEW",
      +[](const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m,
          std::vector<ptzstereo::stereo_frame_t>* out) { out->push_back(*m); },
      previews);
  ChildProcess camera({PTZ_CAMERA_BIN, "--lcm-url", ptz::test::kTestUrl, "--left-source",
                       dir + "/left", "--right-source", dir + "/right", "--width", "1920",
                       "--height", "1080", "--encoding", "jpeg", "--status-period-s", "0.1",
                       "--preview-rate-hz", "5"});
  ptz::test::handleUntil(
      lcm, [&] { return camera.wait(0ms) >= 0; }, 60s);
  ptz::test::drain(lcm, 300ms);
  ASSERT_EQ(camera.wait(0ms), 0) << "ptz-camera exits 0 when both folders ended";
}

}  // namespace

TEST(CameraRecording1080p, PublishesTheRecordedJpegsByteForByteWithTheirTimes) {
  TempDir dir;
  constexpr int kFrames = 30;
  const auto rec = ptz::test::writeSimRecording(dir.path, kScenario, "1080p", kFrames, 30.0, 90);
  ASSERT_EQ(rec.width, 1920);
  ASSERT_EQ(rec.height, 1080);
  EXPECT_EQ(rec.frames_ball_visible, kFrames);  // the home cameras see the ball
  CameraListener l;
  std::vector<ptzstereo::stereo_frame_t> previews;
  play(dir.path, &l, &previews);
  ASSERT_EQ(l.frames.size(), static_cast<size_t>(kFrames));
  // Previews decode the passed-through images: 5 Hz of 30 frames at 30 Hz (seq 0, 6, 12, ...).
  ASSERT_EQ(previews.size(), 5u);
  for (const auto& p : previews) {
    EXPECT_EQ(p.seq % 6, 0);
    EXPECT_EQ(p.left.width, 320);
    EXPECT_EQ(p.left.height, 180);
    cv::Mat image;
    std::string why;
    EXPECT_TRUE(ptz::decodeImage(p.right, &image, &why)) << why;
  }
  for (size_t k = 0; k < l.frames.size(); ++k) {
    const auto& m = l.frames[k];
    EXPECT_EQ(m.seq, static_cast<int64_t>(k));
    EXPECT_EQ(m.utime, rec.utimes[k]);
    EXPECT_EQ(m.left.width, 1920);
    EXPECT_EQ(m.left.height, 1080);
    EXPECT_EQ(m.left.encoding, ptzstereo::image_t::ENCODING_JPEG);
    EXPECT_EQ(m.left.pixel_format, ptzstereo::image_t::PIXEL_BGR8);
    EXPECT_EQ(m.left.data_size, static_cast<int32_t>(m.left.data.size()));
    EXPECT_TRUE(m.left.data == fileBytes(frameFile(dir.path, "left", k))) << "left " << k;
    EXPECT_TRUE(m.right.data == fileBytes(frameFile(dir.path, "right", k))) << "right " << k;
    std::string why;
    EXPECT_TRUE(ptz::checkStereoFrame(m, ptz::kMaxImageSidePx, &why)) << why;
  }
  EXPECT_EQ(l.counters["pairs"], kFrames);
  EXPECT_EQ(l.counters["unmatched_left"], 0);
  EXPECT_EQ(l.counters["unmatched_right"], 0);
  EXPECT_EQ(l.counters["images_passed_through"], 2 * kFrames);
  EXPECT_EQ(l.counters["resized_left"] + l.counters["resized_right"], 0);
  EXPECT_EQ(l.counters["skipped_files_left"] + l.counters["skipped_files_right"], 0);
}

TEST(CameraRecording1080p, AFileThatDoesNotDecodeIsSkippedCountedAndNamed) {
  TempDir dir;
  constexpr int kFrames = 20, kBad = 5, kCut = 12;
  const auto rec = ptz::test::writeSimRecording(dir.path, kScenario, "1080p", kFrames, 30.0, 90);
  const std::string bad = frameFile(dir.path, "left", kBad);
  std::ofstream(bad, std::ios::binary | std::ios::trunc) << "not a JPEG at all";
  // Cut short: its header is fine but not its end, so it is decoded (libjpeg fills the rest in)
  // and re-encoded rather than passed through.
  const std::string cut = frameFile(dir.path, "right", kCut);
  auto bytes = fileBytes(cut);
  bytes.resize(bytes.size() * 3 / 4);
  std::ofstream(cut, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<long>(bytes.size()));
  CameraListener l;
  std::vector<ptzstereo::stereo_frame_t> previews;
  play(dir.path, &l, &previews);
  ASSERT_EQ(l.frames.size(), static_cast<size_t>(kFrames - 1));
  for (size_t i = 0; i < l.frames.size(); ++i) {
    const size_t k = i < kBad ? i : i + 1;
    const auto& m = l.frames[i];
    EXPECT_EQ(m.utime, rec.utimes[k]);
    EXPECT_TRUE(m.left.data == fileBytes(frameFile(dir.path, "left", k))) << "left " << k;
    EXPECT_EQ(m.right.data == fileBytes(frameFile(dir.path, "right", k)), k != kCut) << k;
    std::string why;
    EXPECT_TRUE(ptz::checkStereoFrame(m, ptz::kMaxImageSidePx, &why)) << k << ": " << why;
  }
  EXPECT_EQ(l.counters["skipped_files_left"], 1);
  EXPECT_EQ(l.counters["skipped_files_right"], 0);
  EXPECT_EQ(l.counters["unmatched_right"], 1);  // the bad file's partner
  EXPECT_EQ(l.counters["images_passed_through"], 2 * (kFrames - 1) - 1);
  const std::string named =
      "left source: 1 image file(s) skipped, the last: image file '" + bad + "' does not decode";
  bool said = false;
  for (const auto& message : l.messages) said = said || message.find(named) != std::string::npos;
  EXPECT_TRUE(said) << l.message;
}
