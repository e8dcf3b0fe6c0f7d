// What ptz-camera's main publishes from its library (camera_output.hpp): a recorded pair's waits,
// PTZ_STATE taken or refused, the loop's wait, a passed-through JPEG, a preview's reduced decode.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "ptz_driver/cameras/camera_output.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "support/hardware/fake_frame_source.hpp"

using namespace ptz::driver;
using ptz::test::FakeCamera;

namespace {

constexpr int64_t kStart = 1'700'000'000'000'000;

struct Rig {
  std::shared_ptr<FakeCamera> left = std::make_shared<FakeCamera>();
  std::shared_ptr<FakeCamera> right = std::make_shared<FakeCamera>();
  StereoCamera camera;
  Rig() : camera(config(), {ptz::test::fakeFactory(left), ptz::test::fakeFactory(right)}) {}
  static CameraConfig config() {
    CameraConfig c;
    c.source[0] = parseSource("left.avi", "left_source");
    c.source[1] = parseSource("right.avi", "right_source");
    c.pairer = {12'000, 30, 2.0};
    c.max_rate_hz = 0;
    return c;
  }
};

ptzstereo::ptz_state_t state(int64_t utime, double pan) {
  ptzstereo::ptz_state_t m{};
  m.utime = utime;
  m.left.pan_rad = pan;
  m.right.pan_rad = -pan;
  m.left.zoom = m.right.zoom = 1.0;
  return m;
}

}  // namespace

TEST(CameraOutput, ARecordedPairsWaitsAndPtz) {
  Rig rig;
  ASSERT_TRUE(takePtzState(&rig.camera, state(kStart, 0.25)));
  EXPECT_FALSE(takePtzState(&rig.camera, state(kStart - 1, 0.5))) << "not after the newest";
  ASSERT_TRUE(takePtzState(&rig.camera, state(kStart + 20'000, 0.45)));
  rig.left->push(kStart + 10'000, 0);
  rig.right->push(kStart + 14'000, 0);
  std::vector<StampedPair> pairs;
  for (int i = 0; i < 100 && pairs.empty(); ++i) pairs = rig.camera.step(kStart + 30'000);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_NEAR(pairs[0].left_pose.pan_rad, 0.35, 1e-9);  // interpolated at its capture time
  EXPECT_NEAR(pairs[0].right_pose.pan_rad, -0.39, 1e-9);
  EXPECT_EQ(pollTimeoutMs(rig.camera, kStart + 30'000, 50), 50) << "nothing held";
  PairWaits waits;
  waits.add(pairs[0], pairs[0].first_arrival_utime + 7'000);
  EXPECT_EQ(waits.wait_ms, std::vector<double>{7.0});
  EXPECT_EQ(waits.ptz_wait_ms, std::vector<double>{pairs[0].ptz_wait_us / 1000.0});
  EXPECT_EQ(rig.camera.counters().at("unmatched_left"), 0);
}

TEST(CameraOutput, APassedThroughJpegGoesAsItIs) {
  CapturedFrame f;
  f.jpeg = {0xFF, 0xD8, 0x01, 0xFF, 0xD9};
  f.jpeg_size = {640, 480};
  const auto m = passedThroughImage(&f, {0.1, -0.2, 3.0});
  EXPECT_EQ(m.width, 640);
  EXPECT_EQ(m.height, 480);
  EXPECT_EQ(m.row_stride, 1920);
  EXPECT_EQ(m.encoding, ptzstereo::image_t::ENCODING_JPEG);
  EXPECT_EQ(m.data, (std::vector<uint8_t>{0xFF, 0xD8, 0x01, 0xFF, 0xD9}));
  EXPECT_EQ(m.data_size, 5);
  EXPECT_DOUBLE_EQ(m.tilt_rad, -0.2);
  EXPECT_TRUE(f.jpeg.empty()) << "moved, not copied";
}

TEST(CameraOutput, APreviewDecodesReducedToAtLeastItsWidth) {
  std::vector<uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", cv::Mat(480, 640, CV_8UC3, cv::Scalar(10, 20, 30)), jpeg));
  EXPECT_EQ(reducedDecode(jpeg, 640, 80).size(), cv::Size(80, 60));
  EXPECT_EQ(reducedDecode(jpeg, 640, 160).size(), cv::Size(160, 120));
  EXPECT_EQ(reducedDecode(jpeg, 640, 200).size(), cv::Size(320, 240));
  EXPECT_EQ(reducedDecode(jpeg, 640, 400).size(), cv::Size(640, 480));
  StampedPair p;
  p.left.jpeg_size = p.right.jpeg_size = {640, 480};
  ptzstereo::stereo_frame_t msg{};
  msg.left.data = jpeg;
  msg.right.data = {1, 2, 3};  // does not decode
  EXPECT_FALSE(previewPixels(&p, msg, 160));
  EXPECT_EQ(p.left.image.size(), cv::Size(160, 120));
  EXPECT_EQ(statusState(Health::kWarn), ptzstereo::process_status_t::STATE_WARN);
}
