// The intake every process puts before its inputs: the freshness gate's reasons and prefixes, and
// a frame's checks against the rig, each drop counted once under its reason.
#include <gtest/gtest.h>

#include "common/config.hpp"
#include "common/transport/intake.hpp"

namespace {

ptz::Params statusParams() {
  ptz::Params p("ptz-test", "");
  ptz::addTransportParams(p);
  return p;
}

constexpr int64_t kNowUs = 1'700'000'000'000'000;

ptzstereo::stereo_frame_t frameOf(int width, int height, int64_t capture_utime, int64_t seq) {
  const cv::Mat image(height, width, CV_8UC3, cv::Scalar(10, 20, 30));
  auto m = ptz::makeStereoFrame(capture_utime, seq, image, {}, image, {},
                                ptzstereo::image_t::ENCODING_RAW, 90);
  m.publish_utime = capture_utime + 1000;
  return m;
}

class Intake : public ::testing::Test {
 protected:
  lcm::LCM lcm{"memq://"};
  ptz::Params params = statusParams();
  ptz::StatusReporter status{&lcm, params, "ptz-test"};
  ptz::FreshnessLimits limits{500'000, 100'000};
};

}  // namespace

TEST_F(Intake, GateAdmitsFreshAndCountsStaleAndFutureUnderItsPrefix) {
  ptz::FreshnessGate gate(status, limits, "setpoint", "setpoint_", ptz::CaptureClock::kWall);
  EXPECT_TRUE(gate.admit("PTZ_SETPOINT", kNowUs - 400'000, kNowUs - 1000, 7, kNowUs));
  EXPECT_FALSE(gate.admit("PTZ_SETPOINT", kNowUs - 600'000, kNowUs - 1000, 8, kNowUs));
  EXPECT_FALSE(gate.admit("PTZ_SETPOINT", kNowUs + 200'000, kNowUs + 200'000, 9, kNowUs));
  EXPECT_EQ(status.counter("dropped_setpoint_stale"), 1);
  EXPECT_EQ(status.counter("dropped_setpoint_future"), 1);
}

TEST_F(Intake, GateJudgesSimTimeCapturesByTheirPublishTimeAlone) {
  // A lockstep run's capture times are sim time: 1 s after the epoch, published now.
  ptz::FreshnessGate automatic(status, limits, "frame");
  EXPECT_TRUE(automatic.admit("STEREO_FRAME", 1'000'000, kNowUs - 1000, 1, kNowUs));
  ptz::FreshnessGate wall(status, limits, "frame", "", ptz::CaptureClock::kWall);
  EXPECT_FALSE(wall.admit("STEREO_FRAME", 1'000'000, kNowUs - 1000, 1, kNowUs));
  EXPECT_EQ(status.counter("dropped_stale"), 1);
}

TEST_F(Intake, FrameOfTheRigsSizeIsAcceptedAndDecoded) {
  ptz::FrameIntake intake(status, "STEREO_FRAME", limits, {64, 48}, "");
  const auto m = frameOf(64, 48, kNowUs - 10'000, 3);
  ASSERT_TRUE(intake.accept(m, kNowUs));
  cv::Mat left, right;
  ASSERT_TRUE(intake.decode(m, &left, &right));
  EXPECT_EQ(left.size(), cv::Size(64, 48));
  EXPECT_EQ(right.at<cv::Vec3b>(5, 5), cv::Vec3b(10, 20, 30));
  EXPECT_EQ(status.counter("dropped_size_mismatch"), 0);
}

TEST_F(Intake, FrameOfAnotherSizeOrStaleOrBrokenIsDroppedUnderItsReason) {
  ptz::FrameIntake intake(status, "STEREO_FRAME", limits, {64, 48}, "rig.yaml");
  EXPECT_FALSE(intake.accept(frameOf(32, 48, kNowUs - 10'000, 1), kNowUs));
  EXPECT_FALSE(intake.accept(frameOf(64, 48, kNowUs - 900'000, 2), kNowUs));
  auto broken = frameOf(64, 48, kNowUs - 10'000, 3);
  broken.left.data.resize(10);
  broken.left.data_size = 10;
  EXPECT_FALSE(intake.accept(broken, kNowUs));
  EXPECT_EQ(status.counter("dropped_size_mismatch"), 1);
  EXPECT_EQ(status.counter("dropped_stale"), 1);
  EXPECT_EQ(status.counter("dropped_bad_image"), 1);
}

TEST_F(Intake, AFrameThatWentStaleWhileProcessedIsDroppedOnce) {
  ptz::FrameIntake intake(status, "STEREO_FRAME", limits, {64, 48}, "");
  const auto m = frameOf(64, 48, kNowUs - 10'000, 4);
  ASSERT_TRUE(intake.accept(m, kNowUs));
  EXPECT_TRUE(intake.stillFresh(m, kNowUs + 400'000));     // processed within the age limit
  EXPECT_FALSE(intake.stillFresh(m, kNowUs + 3'000'000));  // stopped for 3 s mid-frame
  EXPECT_EQ(status.counter("dropped_stale"), 1);
}

TEST_F(Intake, AnswersToAFrameThatWentStaleMidSendAreWithheldNotDroppedTwice) {
  ptz::FrameIntake intake(status, "STEREO_FRAME", limits, {64, 48}, "");
  const auto m = frameOf(64, 48, kNowUs - 10'000, 5);
  ASSERT_TRUE(intake.accept(m, kNowUs));
  EXPECT_TRUE(intake.mayAnswer(m, kNowUs + 100'000));
  EXPECT_FALSE(intake.mayAnswer(m, kNowUs + 3'000'000));  // stopped between two publishes
  EXPECT_EQ(status.counter("answers_withheld_stale"), 1);
  EXPECT_EQ(status.counter("dropped_stale"), 0);
}
