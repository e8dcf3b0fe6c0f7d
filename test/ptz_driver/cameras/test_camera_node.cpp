// ptz-camera's library as a whole with scripted cameras: images stamped with the PTZ of their own
// capture time, the publish-rate limit, what the status says, the end of both files, and the
// parameters' checks.
#include <gtest/gtest.h>

#include <cmath>

#include "ptz_driver/cameras/stereo_camera.hpp"
#include "support/hardware/fake_frame_source.hpp"

using namespace ptz::driver;
using ptz::test::FakeCamera;

namespace {

constexpr int64_t kStart = 1'700'000'000'000'000;

CameraConfig config(double max_rate_hz) {
  CameraConfig c;
  c.source[0] = parseSource("left.avi", "left_source");
  c.source[1] = parseSource("right.avi", "right_source");
  c.pairer = {12'000, 30, 2.0};
  c.max_rate_hz = max_rate_hz;
  return c;
}

struct Rig {
  std::shared_ptr<FakeCamera> left = std::make_shared<FakeCamera>();
  std::shared_ptr<FakeCamera> right = std::make_shared<FakeCamera>();
  StereoCamera camera;
  explicit Rig(const CameraConfig& c)
      : camera(c, {ptz::test::fakeFactory(left), ptz::test::fakeFactory(right)}) {}
};

// Known PTZ as a function of time: pan 0.1 + 0.2 t, tilt -0.05 + 0.1 t, zoom 1 + 0.5 t (t in s
// from kStart), the right camera the mirror image in pan.
ptz::PtzPose truth(ptz::Side side, int64_t utime) {
  const double t = static_cast<double>(utime - kStart) * 1e-6;
  const double pan = 0.1 + 0.2 * t;
  return {side == ptz::Side::kLeft ? pan : -pan, -0.05 + 0.1 * t, 1.0 + 0.5 * t};
}

std::string health(const StereoCamera& c, int64_t now, Health* h) {
  std::string message;
  *h = c.health(now, &message);
  return message;
}

}  // namespace

TEST(CameraNode, EachImageCarriesThePtzOfItsOwnCaptureTime) {
  Rig rig(config(0));
  for (int j = 0; j <= 50; ++j) {  // 1 s of states at 50 Hz
    const int64_t t = kStart + j * 20'000;
    ASSERT_TRUE(rig.camera.onPtzState(t, truth(ptz::Side::kLeft, t), truth(ptz::Side::kRight, t)));
  }
  for (int k = 0; k < 20; ++k) {  // 25 Hz, right 8 ms later
    rig.left->push(kStart + k * 40'000, k);
    rig.right->push(kStart + k * 40'000 + 8'000, k);
  }
  const auto pairs = rig.camera.step(kStart + 800'000);
  ASSERT_EQ(pairs.size(), 20u);
  for (const auto& p : pairs) {
    EXPECT_EQ(p.left.index, p.right.index);
    EXPECT_FALSE(p.ptz_stale);
    const auto l = truth(ptz::Side::kLeft, p.left.capture_utime);
    const auto r = truth(ptz::Side::kRight, p.right.capture_utime);
    EXPECT_NEAR(p.left_pose.pan_rad, l.pan_rad, 1e-12);
    EXPECT_NEAR(p.left_pose.tilt_rad, l.tilt_rad, 1e-12);
    EXPECT_NEAR(p.left_pose.zoom, l.zoom, 1e-12);
    EXPECT_NEAR(p.right_pose.pan_rad, r.pan_rad, 1e-12);
    EXPECT_NEAR(p.right_pose.zoom, r.zoom, 1e-12);
  }
  Health h;
  EXPECT_EQ(health(rig.camera, kStart + 800'000, &h), "");
  EXPECT_EQ(h, Health::kOk);
  // Frames 0.2 s after the last state: published with the last state, counted, status WARN.
  rig.left->push(kStart + 1'200'000, 30);
  rig.right->push(kStart + 1'200'000, 30);
  const auto late = rig.camera.step(kStart + 1'300'000);
  ASSERT_EQ(late.size(), 1u);
  EXPECT_TRUE(late[0].ptz_stale);
  EXPECT_NEAR(late[0].left_pose.pan_rad, truth(ptz::Side::kLeft, kStart + 1'000'000).pan_rad,
              1e-12);
  EXPECT_EQ(rig.camera.counters().at("ptz_stale"), 1);
  EXPECT_EQ(health(rig.camera, kStart + 1'300'000, &h),
            "frames without a PTZ_STATE near their capture time: stamped with the nearest state "
            "(home without any)");
  EXPECT_EQ(h, Health::kWarn);
}

TEST(CameraNode, PairsWaitForTheStatesThatArriveAfterThemAndAreInterpolated) {
  CameraConfig c = config(0);
  c.source[0] = parseSource("0", "left_source");  // live cameras: capture times are wall clock
  c.source[1] = parseSource("1", "right_source");
  Rig rig(c);
  // States every 20 ms, each arriving 30 ms after its time (mid round trip, 50 Hz, LCM); frames
  // at 25 Hz (right 7 ms after left), each arriving 5 ms after its capture. Explicit time in
  // 5 ms steps; the states start before the first frame.
  constexpr int64_t kStateDelay = 30'000, kFrameDelay = 5'000;
  int64_t next_state = kStart - 100'000;
  int next_frame = 0;
  std::vector<std::pair<StampedPair, int64_t>> published;  // with the time it was released
  for (int64_t now = kStart - 100'000; now <= kStart + 1'000'000; now += 5'000) {
    for (; next_state + kStateDelay <= now; next_state += 20'000) {
      ASSERT_TRUE(rig.camera.onPtzState(next_state, truth(ptz::Side::kLeft, next_state),
                                        truth(ptz::Side::kRight, next_state)));
    }
    for (; next_frame < 20 && kStart + next_frame * 40'000 + 10'000 + kFrameDelay <= now;
         ++next_frame) {
      rig.left->push(kStart + next_frame * 40'000 + 3'000, next_frame);
      rig.right->push(kStart + next_frame * 40'000 + 10'000, next_frame);
    }
    for (auto& p : rig.camera.step(now)) published.emplace_back(std::move(p), now);
  }
  ASSERT_EQ(published.size(), 20u);
  for (const auto& [p, released] : published) {
    EXPECT_EQ(p.left.index, p.right.index);
    EXPECT_FALSE(p.ptz_stale);
    const auto l = truth(ptz::Side::kLeft, p.left.capture_utime);
    const auto r = truth(ptz::Side::kRight, p.right.capture_utime);
    EXPECT_NEAR(p.left_pose.pan_rad, l.pan_rad, 1e-12) << "pair " << p.left.index;
    EXPECT_NEAR(p.left_pose.tilt_rad, l.tilt_rad, 1e-12);
    EXPECT_NEAR(p.left_pose.zoom, l.zoom, 1e-12);
    EXPECT_NEAR(p.right_pose.pan_rad, r.pan_rad, 1e-12) << "pair " << p.left.index;
    EXPECT_NEAR(p.right_pose.tilt_rad, r.tilt_rad, 1e-12);
    EXPECT_NEAR(p.right_pose.zoom, r.zoom, 1e-12);
    // Released by the first state at or after the right capture: at most a state period and
    // the state's delay after it (the pair was made on the right frame's arrival).
    EXPECT_EQ(p.ptz_wait_us, released - (p.right.capture_utime + kFrameDelay));
    EXPECT_GT(p.ptz_wait_us, 0);
    EXPECT_LE(released, p.right.capture_utime + 20'000 + kStateDelay);
  }
  EXPECT_EQ(rig.camera.counters().at("ptz_stale"), 0);
  EXPECT_EQ(rig.camera.counters().at("ptz_extrapolated"), 0);
  EXPECT_FALSE(rig.camera.heldUntilUtime().has_value());
}

TEST(CameraNode, WithoutAStateToWaitForPairsAreNotDelayed) {
  CameraConfig c = config(0);
  c.source[0] = parseSource("0", "left_source");
  c.source[1] = parseSource("1", "right_source");
  Rig rig(c);
  // No PTZ_STATE ever (no driver): published at once, stale.
  for (int k = 0; k < 5; ++k) {
    rig.left->push(kStart + k * 40'000, k);
    rig.right->push(kStart + k * 40'000 + 1'000, k);
  }
  const auto none = rig.camera.step(kStart + 161'000);
  ASSERT_EQ(none.size(), 5u);
  for (const auto& p : none) {
    EXPECT_TRUE(p.ptz_stale);
    EXPECT_EQ(p.ptz_wait_us, 0);
  }
  EXPECT_FALSE(rig.camera.heldUntilUtime().has_value());
  // A driver whose last state is older than max_ptz_extrapolation_s (0.1 s): stale whatever
  // arrives, published at once.
  ASSERT_TRUE(rig.camera.onPtzState(kStart, truth(ptz::Side::kLeft, kStart),
                                    truth(ptz::Side::kRight, kStart)));
  rig.left->push(kStart + 200'000, 5);
  rig.right->push(kStart + 201'000, 5);
  const auto gone = rig.camera.step(kStart + 202'000);
  ASSERT_EQ(gone.size(), 1u);
  EXPECT_TRUE(gone[0].ptz_stale);
  EXPECT_EQ(gone[0].ptz_wait_us, 0);
  // States that stop for a moment: the pair waits max_ptz_extrapolation_s after its (later)
  // capture, then takes the newest state, not stale.
  ASSERT_TRUE(rig.camera.onPtzState(kStart + 230'000, truth(ptz::Side::kLeft, kStart + 230'000),
                                    truth(ptz::Side::kRight, kStart + 230'000)));
  rig.left->push(kStart + 240'000, 6);
  rig.right->push(kStart + 241'000, 6);
  EXPECT_TRUE(rig.camera.step(kStart + 250'000).empty());
  ASSERT_TRUE(rig.camera.heldUntilUtime().has_value());
  EXPECT_EQ(*rig.camera.heldUntilUtime(), kStart + 341'000);
  EXPECT_TRUE(rig.camera.step(kStart + 340'999).empty());
  const auto late = rig.camera.step(kStart + 341'000);
  ASSERT_EQ(late.size(), 1u);
  EXPECT_FALSE(late[0].ptz_stale);
  EXPECT_EQ(late[0].ptz_wait_us, 91'000);
  EXPECT_NEAR(late[0].left_pose.pan_rad, truth(ptz::Side::kLeft, kStart + 230'000).pan_rad, 1e-12);
  EXPECT_EQ(rig.camera.counters().at("ptz_extrapolated"), 2);  // this one and the stale one
}

TEST(CameraNode, ARecordingWaitsForItsPartnerInsteadOfOverflowingAndALiveCameraCannot) {
  CameraConfig c = config(0);
  c.pairer.buffer_frames = 10;
  Rig files(c);
  for (int k = 0; k < 40; ++k) files.left->push(kStart + k * 40'000, k);
  for (int step = 0; step < 5; ++step) files.camera.step(kStart + step * 10'000);
  EXPECT_EQ(files.camera.counters().at("unmatched_left"), 0);
  EXPECT_EQ(files.camera.counters().at("frames_left"), 10);  // the rest waits in the source
  for (int k = 0; k < 40; ++k) files.right->push(kStart + k * 40'000 + 1'000, k);
  size_t pairs = 0;
  for (int step = 0; step < 10; ++step) pairs += files.camera.step(kStart + 100'000).size();
  EXPECT_EQ(pairs, 40u);
  EXPECT_EQ(files.camera.counters().at("unmatched_left"), 0);

  c.source[0] = parseSource("0", "left_source");  // a V4L2 camera
  Rig live(c);
  for (int k = 0; k < 40; ++k) live.left->push(kStart + k * 40'000, k);
  live.camera.step(kStart);
  EXPECT_EQ(live.camera.counters().at("frames_left"), 40);
  EXPECT_EQ(live.camera.counters().at("unmatched_left"), 30);
}

TEST(CameraNode, PairsBeyondTheMaximumRateAreSkippedAndCounted) {
  Rig rig(config(30.0));
  for (int k = 0; k < 20; ++k) {  // 60 Hz
    rig.left->push(kStart + k * 16'667, k);
    rig.right->push(kStart + k * 16'667, k);
  }
  rig.left->end_after_queue = rig.right->end_after_queue = true;
  const auto pairs = rig.camera.step(kStart + 400'000);
  ASSERT_EQ(pairs.size(), 10u);
  for (size_t i = 0; i < pairs.size(); ++i) EXPECT_EQ(pairs[i].left.index, 2 * i);
  const auto c = rig.camera.counters();
  EXPECT_EQ(c.at("pairs"), 20);
  EXPECT_EQ(c.at("pairs_skipped_rate"), 10);
  EXPECT_EQ(c.at("ptz_stale"), 10);  // no PTZ_STATE at all
  EXPECT_TRUE(rig.camera.finished());
  EXPECT_EQ(c.at("ended_left"), 1);
  EXPECT_EQ(c.at("ended_right"), 1);
}

TEST(CameraNode, TheStatusNamesAFailingSourceAndARigThatDoesNotPair) {
  Rig rig(config(0));
  rig.left->opens = false;
  rig.camera.step(kStart);
  Health h;
  EXPECT_EQ(health(rig.camera, kStart, &h),
            "left source left.avi: cannot open: no such camera, reconnecting in 0.5 s");
  EXPECT_EQ(h, Health::kError);
  EXPECT_EQ(rig.camera.counters().at("reconnects_left"), 1);
  EXPECT_EQ(rig.camera.counters().at("reconnects_right"), 0);
  rig.left->opens = true;
  for (int k = 0; k < 80; ++k) {  // right 17 ms after left: never within 12 ms
    const int64_t t = kStart + 500'000 + k * 40'000;
    rig.left->push(t, k);
    rig.right->push(t + 17'000, k);
    rig.camera.step(t + 17'000);
  }
  // Both deliver since kStart + 0.517 s.
  const int64_t now = kStart + 500'000 + 79 * 40'000 + 17'000;
  EXPECT_EQ(health(rig.camera, now, &h),
            "no stereo pair in 3.2 s: right is 0.017 s behind left (tolerance 0.012 s); check the "
            "clocks or raise pair_tolerance_s");
  EXPECT_EQ(h, Health::kError);
  EXPECT_EQ(rig.camera.counters().at("pairs"), 0);
}

TEST(CameraNode, ParametersAreCheckedWithTheParameterNamed) {
  auto error = [](const std::vector<std::pair<std::string, std::string>>& values) {
    ptz::Params p("ptz-camera", "test");
    declareCameraParams(p);
    p.set("left_source", "left.avi");
    p.set("right_source", "right.avi");
    try {
      for (const auto& [k, v] : values) p.set(k, v);
      cameraConfigFrom(p);
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("ok");
  };
  EXPECT_EQ(error({}), "ok");
  EXPECT_EQ(error({{"right_source", ""}}),
            "parameter 'right_source' is empty: name a camera or file");
  EXPECT_EQ(error({{"left_source", "0"}, {"left_timestamps", "t.txt"}}),
            "parameter 'left_timestamps' is for video files and folders; left_source is a V4L2 "
            "camera");
  EXPECT_EQ(error({{"right_timestamps", "/nonexistent.timestamps"}}),
            "timestamps file '/nonexistent.timestamps': cannot open");
  EXPECT_EQ(error({{"pair_tolerance_s", "-0.01"}}),
            "set: parameter 'pair_tolerance_s' must be within 0 .. 10, got '-0.01'");
  EXPECT_EQ(error({{"retry_initial_s", "0"}}),
            "set: parameter 'retry_initial_s' must be > 0, got '0'");
  EXPECT_EQ(error({{"retry_initial_s", "10"}}),
            "parameter 'retry_initial_s' = 10 (set) must be at most parameter 'retry_max_s' = 8 "
            "(default)");
  EXPECT_EQ(error({{"width", "0"}}),
            "set: parameter 'width' may be 0 only when height is 0 too, got '0'");
  EXPECT_EQ(error({{"width", "20000"}}),
            "set: parameter 'width' must be within 0 .. 16384, got '20000'");
  EXPECT_EQ(error({{"fourcc", "MJPEG"}}),
            "set: parameter 'fourcc' must be four characters, got 'MJPEG'");
}

TEST(CameraNode, TheExampleConfigsLoad) {
  for (const char* name : {"camera_files.yaml", "camera_rtsp.yaml", "camera_usb_trigger.yaml"}) {
    ptz::Params p("ptz-camera", "test");
    declareCameraParams(p);
    p.add("encoding", "raw", "declared by ptz-camera's main (transport)");
    p.add("jpeg_quality", 90, "", "declared by ptz-camera's main (transport)");
    p.parseConfigFile(std::string(PTZ_SOURCE_DIR) + "/config/" + name);
    const CameraConfig c = cameraConfigFrom(p);
    EXPECT_EQ(c.pairer.tolerance_us, c.trigger.enabled() ? 5'000 : 15'000) << name;
    EXPECT_EQ(c.capture[0].width, 640) << name;
    EXPECT_EQ(c.trigger.enabled(), std::string(name) == "camera_usb_trigger.yaml") << name;
  }
}
