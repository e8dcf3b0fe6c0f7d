// The LCM edge every process shares: checked subscriptions (newest-only delivery, sequence gaps,
// undecodable messages counted) over memq://, and the health rules of the status with an injected
// clock.
#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <vector>

#include "common/config.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace {

ptzstereo::object_pose_t poseFor(int64_t seq) {
  ptzstereo::object_pose_t m{};
  m.frame_seq = seq;
  m.target_index = -1;
  return m;
}

ptz::Params statusParams() {
  ptz::Params p("ptz-test", "");
  ptz::addTransportParams(p);
  return p;
}

// One process's LCM edge on memq://: its status reporter and what its subscriptions handled.
class Edge : public ::testing::Test {
 protected:
  lcm::LCM lcm{"memq://"};
  ptz::Params params = statusParams();
  ptz::StatusReporter status{&lcm, params, "ptz-test"};
  std::vector<int64_t> handled;
  // Every status the reporter publishes, into got.
  std::unique_ptr<ptz::SafeSubscription<ptzstereo::process_status_t>> listenToStatus(
      std::vector<ptzstereo::process_status_t>* got) {
    return std::make_unique<ptz::SafeSubscription<ptzstereo::process_status_t>>(
        lcm, "PROCESS_STATUS_PTZ_TEST", status,
        [got](const std::string&, const ptzstereo::process_status_t& m) { got->push_back(m); });
  }
  void publishPose(int64_t seq) {
    const auto m = poseFor(seq);
    lcm.publish("OBJECT_POSE", &m);
  }
  ptz::SafeSubscription<ptzstereo::object_pose_t>::Handler recordPose() {
    return [this](const std::string&, const ptzstereo::object_pose_t& m) {
      handled.push_back(m.frame_seq);
    };
  }
};

}  // namespace

TEST_F(Edge, NewestDeliveryDrainsTheBacklogAndHandsOverOnlyTheLast) {
  std::vector<int64_t> handled;
  ptz::SafeSubscription<ptzstereo::object_pose_t> sub(
      lcm, "OBJECT_POSE", status,
      [&](const std::string&, const ptzstereo::object_pose_t& m) {
        handled.push_back(m.frame_seq);
      },
      ptz::Delivery::kNewest);
  for (int64_t seq = 0; seq < 6; ++seq) {
    const auto m = poseFor(seq);
    lcm.publish("OBJECT_POSE", &m);
  }
  EXPECT_GT(ptz::handleNewest(lcm, 0), 0);
  EXPECT_EQ(handled, std::vector<int64_t>{5});
  EXPECT_EQ(status.counter("dropped_superseded"), 5);
  EXPECT_EQ(status.counter("OBJECT_POSE.dropped_superseded"), 5);
  EXPECT_EQ(status.counter("dropped_seq_gap"), 0);
  EXPECT_EQ(ptz::handleNewest(lcm, 0), 0);  // nothing left, nothing handed over twice
  EXPECT_EQ(handled.size(), 1u);
}

TEST_F(Edge, EveryDeliveryKeepsTheOrder) {
  ptz::SafeSubscription<ptzstereo::ptz_setpoint_t> sub(
      lcm, "PTZ_SETPOINT", status, [&](const std::string&, const ptzstereo::ptz_setpoint_t& m) {
        handled.push_back(m.frame_seq);
      });
  for (int64_t seq = 0; seq < 4; ++seq) {
    ptzstereo::ptz_setpoint_t m{};
    m.frame_seq = seq;
    lcm.publish("PTZ_SETPOINT", &m);
  }
  while (ptz::handleNewest(lcm, 0) > 0) {
  }
  EXPECT_EQ(handled, (std::vector<int64_t>{0, 1, 2, 3}));
}

TEST_F(Edge, SequenceGapsAreCountedExactly) {
  ptz::SafeSubscription<ptzstereo::stereo_frame_t> sub(
      lcm, "STEREO_FRAME", status,
      [&](const std::string&, const ptzstereo::stereo_frame_t& m) { handled.push_back(m.seq); });
  // 0 1 2 _ _ 5 6 _ _ _ 10 11: five lost; back to 3 (a restart); a lone hostile 2000000 (an
  // outlier, not two million lost frames), then on from 4; INT64_MAX goes nowhere either.
  for (int64_t seq : {int64_t{0}, int64_t{1}, int64_t{2}, int64_t{5}, int64_t{6}, int64_t{10},
                      int64_t{11}, int64_t{3}, int64_t{2'000'000}, int64_t{4}, int64_t{-1},
                      std::numeric_limits<int64_t>::max(), int64_t{5}}) {
    ptzstereo::stereo_frame_t m{};
    m.seq = seq;
    lcm.publish("STEREO_FRAME", &m);
    ptz::handleNewest(lcm, 0);
  }
  EXPECT_EQ(handled.size(), 13u);
  EXPECT_EQ(status.counter("dropped_seq_gap"), 5);
  EXPECT_EQ(status.counter("STEREO_FRAME.dropped_seq_gap"), 5);
  EXPECT_EQ(status.counter("STEREO_FRAME.seq_restart"), 1);
  EXPECT_EQ(status.counter("STEREO_FRAME.seq_outlier"), 2);
}

TEST_F(Edge, GapsInADerivedSequenceAreToldButNotDroppedAgain) {
  // Frames ptz-detect skipped (and counted) show as gaps in its poses' frame_seq.
  ptz::SafeSubscription<ptzstereo::object_pose_t> sub(lcm, "OBJECT_POSE", status, recordPose());
  for (int64_t seq : {0, 1, 4, 5}) {
    publishPose(seq);
    ptz::handleNewest(lcm, 0);
  }
  EXPECT_EQ(status.counter("OBJECT_POSE.seq_gap"), 2);
  EXPECT_EQ(status.counter("dropped_seq_gap"), 0);
}

TEST_F(Edge, UndecodableMessagesAreDroppedAndCounted) {
  ptz::SafeSubscription<ptzstereo::object_pose_t> sub(lcm, "OBJECT_POSE", status, recordPose(),
                                                      ptz::Delivery::kNewest);
  const uint8_t junk[] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  for (int i = 0; i < 7; ++i) {
    lcm.publish("OBJECT_POSE", junk, sizeof(junk));
    ptz::handleNewest(lcm, 0);
  }
  EXPECT_TRUE(handled.empty());
  EXPECT_EQ(status.counter("dropped_undecodable"), 7);
  EXPECT_EQ(status.counter("OBJECT_POSE.dropped_undecodable"), 7);
}

TEST_F(Edge, StarvingInputTurnsWarnThenErrorAndRecovers) {
  int64_t now = 1'800'000'000'000'000;
  status.useClock([&] { return now; });
  status.expectInput("STEREO_FRAME");
  using S = ptzstereo::process_status_t;
  EXPECT_EQ(status.health().first, S::STATE_OK);
  now += 900'000;
  EXPECT_EQ(status.health().first, S::STATE_OK);
  now += 200'000;
  EXPECT_EQ(status.health().first, S::STATE_WARN);
  EXPECT_EQ(status.health().second, "no STEREO_FRAME for 1 s");
  now += 4'000'000;
  EXPECT_EQ(status.health().first, S::STATE_ERROR);
  EXPECT_EQ(status.health().second, "no STEREO_FRAME for 5 s");
  status.countIn("STEREO_FRAME", 3.0);
  EXPECT_EQ(status.health().first, S::STATE_OK);
  EXPECT_EQ(status.health().second, "");
  // The process's own warning and the starvation are both told.
  status.setState(S::STATE_WARN, "delay p99 400 ms");
  now += 2'000'000;
  EXPECT_EQ(status.health().first, S::STATE_WARN);
  EXPECT_EQ(status.health().second, "delay p99 400 ms; no STEREO_FRAME for 2 s");
}

TEST_F(Edge, ThePublishedStatusCarriesTheHealth) {
  std::vector<ptzstereo::process_status_t> got;
  const auto sub = listenToStatus(&got);
  int64_t now = ptz::wallUtime();
  status.useClock([&] { return now; });
  status.expectInput("OBJECT_POSE");
  now += 6'000'000;
  status.publishNow();
  ASSERT_GT(ptz::handleNewest(lcm, 0), 0);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].state, ptzstereo::process_status_t::STATE_ERROR);
  EXPECT_EQ(got[0].message, "no OBJECT_POSE for 6 s");
}

TEST_F(Edge, AChangeOfHealthIsSaidOnStderrOnceAndTheLastStatusThrice) {
  std::vector<ptzstereo::process_status_t> got;
  const auto sub = listenToStatus(&got);
  int64_t now = ptz::wallUtime();
  status.useClock([&] { return now; });
  status.expectInput("OBJECT_POSE");
  now += 1'100'000;
  testing::internal::CaptureStderr();
  status.publishNow();
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "ptz-test: WARN: no OBJECT_POSE for 1 s\n");
  testing::internal::CaptureStderr();
  now += 1'000'000;
  status.publishNow();  // still WARN: nothing new to say
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  status.countIn("OBJECT_POSE", 1.0);
  testing::internal::CaptureStderr();
  status.publishNow();
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "ptz-test: OK\n");
  while (ptz::handleNewest(lcm, 0) > 0) {
  }
  got.clear();
  status.increment("frames_published", 42);
  status.publishLast();
  while (ptz::handleNewest(lcm, 0) > 0) {
  }
  ASSERT_EQ(got.size(), static_cast<size_t>(ptz::StatusReporter::kLastStatusCopies));
  for (const auto& m : got) {
    EXPECT_EQ(m.utime, got[0].utime);
    ASSERT_EQ(m.counters.size(), 1u);
    EXPECT_EQ(m.counters[0].value, 42);
  }
}

ptz::Params frameParams(const std::string& frame_url) {
  ptz::Params p("ptz-test", "");
  ptz::addTransportParams(p);
  ptz::addFrameOutputParams(p);
  p.set("lcm_url", "memq://");
  p.set("frame_lcm_url", frame_url);
  return p;
}

TEST_F(Edge, BulkDataGoesOnlyWhereFrameLcmUrlSays) {
  const ptzstereo::stereo_frame_t frame{};
  // Unset, or the process's own URL: the process's own LCM.
  for (const char* url : {"", "memq://"}) {
    ptz::FrameOutput same(frameParams(url), lcm);
    EXPECT_EQ(&same.lcm(), &lcm) << url;
    EXPECT_EQ(same.url(), "memq://");
  }
  // Another URL: another LCM, and nothing of it on the process's own.
  ptz::FrameOutput apart(frameParams("memq://?frames"), lcm);
  ASSERT_NE(&apart.lcm(), &lcm);
  int on_own = 0, on_frames = 0;
  ptz::SafeSubscription<ptzstereo::stereo_frame_t> own(
      lcm, "STEREO_FRAME", status,
      [&](const std::string&, const ptzstereo::stereo_frame_t&) { ++on_own; });
  ptz::SafeSubscription<ptzstereo::stereo_frame_t> frames(
      apart.lcm(), "STEREO_FRAME", status,
      [&](const std::string&, const ptzstereo::stereo_frame_t&) { ++on_frames; });
  EXPECT_TRUE(status.publishOn(apart.lcm(), "STEREO_FRAME", frame));
  EXPECT_EQ(ptz::handleNewest(lcm, 0), 0);
  EXPECT_GT(ptz::handleNewest(apart.lcm(), 0), 0);
  EXPECT_EQ(on_own, 0);
  EXPECT_EQ(on_frames, 1);
  // A URL LCM cannot open is refused by name.
  try {
    ptz::FrameOutput bad(frameParams("bogus://x"), lcm);
    ADD_FAILURE() << "a bad frame_lcm_url was taken";
  } catch (const ptz::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("frame_lcm_url"), std::string::npos) << e.what();
  }
}

ptz::Params previewParams(const std::string& rate_hz, const std::string& max_bytes) {
  ptz::Params p("ptz-test", "");
  ptz::addTransportParams(p);
  ptz::addPreviewParams(p);
  p.set("preview_rate_hz", rate_hz);
  p.set("preview_width_px", "160");
  p.set("preview_max_bytes", max_bytes);
  return p;
}

TEST_F(Edge, PreviewsAreSmallAtTheirRateAndNeverOverTheirBound) {
  std::vector<ptzstereo::stereo_frame_t> got;
  ptz::SafeSubscription<ptzstereo::stereo_frame_t> sub(
      lcm, "STEREO_PREVIEW", status,
      [&](const std::string&, const ptzstereo::stereo_frame_t& m) { got.push_back(m); });
  const cv::Mat red(480, 640, CV_8UC3, cv::Scalar(0, 0, 255));
  const cv::Mat blue(480, 640, CV_8UC3, cv::Scalar(255, 0, 0));
  const ptz::PtzPose pose{0.25, -0.5, 2.0};
  ptz::PreviewOutput preview(previewParams("5", "60000"));
  ASSERT_TRUE(preview.enabled());
  // 2 s of frames at 30 Hz: a preview every 0.2 s of capture time, the first at once.
  const int64_t t0 = 1'700'000'000'000'000;
  for (int n = 0; n < 60; ++n) {
    preview.maybePublish(status, lcm, t0 + n * 33'333, n, red, pose, blue, pose);
  }
  while (ptz::handleNewest(lcm, 0) > 0) {
  }
  ASSERT_EQ(got.size(), 10u);
  EXPECT_EQ(got[0].seq, 0);
  EXPECT_EQ(got[1].seq, 6);  // on schedule, though 6 x 33.333 ms falls 2 us short of 0.2 s
  cv::Mat left, right;
  std::string why;
  ASSERT_TRUE(ptz::decodeImage(got[1].left, &left, &why)) << why;
  ASSERT_TRUE(ptz::decodeImage(got[1].right, &right, &why)) << why;
  EXPECT_EQ(left.size(), cv::Size(160, 120));
  EXPECT_NEAR(left.at<cv::Vec3b>(60, 80)[2], 255, 3);   // still red
  EXPECT_NEAR(right.at<cv::Vec3b>(60, 80)[0], 255, 3);  // still blue
  EXPECT_DOUBLE_EQ(got[1].left.pan_rad, 0.25);
  EXPECT_DOUBLE_EQ(got[1].left.zoom, 2.0);
  // Noise does not compress: over the bound, counted and not sent.
  cv::Mat noise(480, 640, CV_8UC3);
  cv::randu(noise, 0, 255);
  ptz::PreviewOutput bounded(previewParams("5", "1000"));
  got.clear();
  bounded.maybePublish(status, lcm, t0, 0, noise, pose, noise, pose);
  while (ptz::handleNewest(lcm, 0) > 0) {
  }
  EXPECT_TRUE(got.empty());
  EXPECT_EQ(status.counter("previews_too_large"), 1);
  // Rate 0: none at all.
  ptz::PreviewOutput off(previewParams("0", "60000"));
  EXPECT_FALSE(off.enabled());
  off.maybePublish(status, lcm, t0, 0, red, pose, blue, pose);
  EXPECT_EQ(ptz::handleNewest(lcm, 0), 0);
}

// A rate taken from a stream stamped in capture time: exact on average whatever the two rates,
// and started again after a silence or a time that goes back.
TEST(RateSchedule, TakesTheRateOnAverageAndRestarts) {
  const int64_t t0 = 1'700'000'000'000'000;
  for (const double rate_hz : {1.0, 5.0, 7.0, 30.0}) {
    ptz::RateSchedule s(rate_hz);
    int taken = 0;
    for (int n = 0; n < 300; ++n) taken += s.take(t0 + n * 33'333);  // 10 s at 30 Hz
    EXPECT_NEAR(taken, rate_hz * 10, 1) << rate_hz << " Hz";
  }
  ptz::RateSchedule s(5.0);
  EXPECT_TRUE(s.take(t0));
  EXPECT_FALSE(s.take(t0 + 100'000));
  EXPECT_TRUE(s.take(t0 + 199'000));    // within a hundredth of the period: on schedule
  EXPECT_TRUE(s.take(t0 - 5'000'000));  // back in time: a restarted source
  EXPECT_FALSE(s.take(t0 - 4'900'000));
  EXPECT_TRUE(s.take(t0 + 60'000'000));  // after a silence: at once, then every 0.2 s again
  EXPECT_FALSE(s.take(t0 + 60'100'000));
  EXPECT_TRUE(s.take(t0 + 60'200'000));
  EXPECT_FALSE(ptz::RateSchedule(0).take(t0));
}

TEST_F(Edge, SetCountersTakesAMapOrAListOfPairs) {
  status.setCounters(std::map<std::string, int64_t>{{"a", 1}, {"b", -2}});
  status.setCounters(std::vector<std::pair<std::string, int64_t>>{{"b", 7}, {"c", 3}});
  EXPECT_EQ(status.counter("a"), 1);
  EXPECT_EQ(status.counter("b"), 7);
  EXPECT_EQ(status.counter("c"), 3);
}
