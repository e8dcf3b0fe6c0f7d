// ptz-camera's reconnection state machine against a scripted camera, in explicit time: the
// back-off schedule 0.5, 1, 2, 4, 8, 8 s, the timeouts, and what the status says.
#include <gtest/gtest.h>

#include <vector>

#include "ptz_driver/cameras/sources/source_supervisor.hpp"
#include "support/hardware/fake_frame_source.hpp"

using ptz::driver::CapturedFrame;
using ptz::driver::SourceSupervisor;
using ptz::driver::SupervisorParams;
using ptz::test::FakeCamera;
using State = SourceSupervisor::State;

namespace {

// Steps the supervisor every 1/8 s (exact in binary) from `from_s` to `to_s`; returns the times
// at which a new connection was made.
std::vector<double> stepUntil(SourceSupervisor& s, FakeCamera& cam, double from_s, double to_s,
                              std::vector<CapturedFrame>* frames) {
  std::vector<double> attempts;
  for (double t = from_s; t <= to_s; t += 0.125) {
    const int before = cam.connections;
    s.step(t, frames);
    if (cam.connections > before) attempts.push_back(t);
  }
  return attempts;
}

}  // namespace

TEST(CameraSupervisor, ACameraThatNeverOpensIsRetriedWithExponentialBackOff) {
  auto cam = std::make_shared<FakeCamera>();
  cam->opens = false;
  SourceSupervisor s("left source /dev/video0", ptz::test::fakeFactory(cam), SupervisorParams{});
  std::vector<CapturedFrame> frames;
  const auto attempts = stepUntil(s, *cam, 0.0, 40.0, &frames);
  // Fails at once each time; waits 0.5, 1, 2, 4, 8 (the ceiling), 8, 8 s.
  EXPECT_EQ(attempts, (std::vector<double>{0, 0.5, 1.5, 3.5, 7.5, 15.5, 23.5, 31.5, 39.5}));
  EXPECT_EQ(s.reconnects(), 9);
  EXPECT_EQ(s.state(), State::kWaiting);
  EXPECT_EQ(s.problem(40.0),
            "left source /dev/video0: cannot open: no such camera, reconnecting in 7.5 s");
  EXPECT_TRUE(frames.empty());
}

TEST(CameraSupervisor, AStreamThatStopsIsGivenUpAfterTheTimeoutAndTheBackOffStartsOver) {
  auto cam = std::make_shared<FakeCamera>();
  SourceSupervisor s("right source rtsp://cam/stream", ptz::test::fakeFactory(cam),
                     SupervisorParams{2.0, 10.0, 0.5, 8.0});
  std::vector<CapturedFrame> frames;
  for (int k = 0; k <= 8; ++k) {  // frames for 1 s, then silence
    cam->push(k * 125'000);
    s.step(k * 0.125, &frames);
  }
  EXPECT_EQ(frames.size(), 9u);
  EXPECT_EQ(s.state(), State::kStreaming);
  EXPECT_EQ(s.problem(1.0), "");
  s.step(3.0, &frames);  // 2.0 s after the last frame: not yet
  EXPECT_EQ(s.state(), State::kStreaming);
  s.step(3.125, &frames);
  EXPECT_EQ(s.state(), State::kWaiting);
  EXPECT_EQ(s.reconnects(), 1);
  EXPECT_EQ(s.problem(3.125),
            "right source rtsp://cam/stream: no frame for 2.1 s, reconnecting in 0.5 s");
  // The camera is back: the retry at 3.625 s connects, a frame comes, then silence again; the
  // back-off starts over at 0.5 s.
  s.step(3.5, &frames);
  EXPECT_EQ(cam->connections, 1);
  s.step(3.625, &frames);
  EXPECT_EQ(s.state(), State::kConnecting);
  EXPECT_EQ(s.problem(3.625),
            "right source rtsp://cam/stream: no frame for 2.1 s, reconnecting (attempt 2)");
  cam->push(4'000'000);
  s.step(3.75, &frames);
  EXPECT_EQ(s.state(), State::kStreaming);
  EXPECT_EQ(cam->connections, 2);
  EXPECT_EQ(s.nextDelayS(), 0.5);
  s.step(5.875, &frames);
  EXPECT_EQ(s.state(), State::kWaiting);
  EXPECT_EQ(s.retryAtS(), 6.375);
  EXPECT_EQ(s.frames(), 10);
  const auto events = s.takeEvents();
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0], "right source rtsp://cam/stream: no frame for 2.1 s, reconnecting in 0.5 s");
  EXPECT_EQ(events[1], "right source rtsp://cam/stream: frames again");
  EXPECT_TRUE(s.takeEvents().empty());
}

TEST(CameraSupervisor, AnUnpluggedCameraIsReconnectedAndSaysSo) {
  auto cam = std::make_shared<FakeCamera>();
  SourceSupervisor s("left source 0", ptz::test::fakeFactory(cam), SupervisorParams{});
  std::vector<CapturedFrame> frames;
  cam->push(1);
  cam->push(2);
  cam->fail_after_queue = true;
  s.step(0.0, &frames);
  EXPECT_EQ(frames.size(), 2u);
  EXPECT_EQ(s.state(), State::kWaiting);
  EXPECT_EQ(s.problem(0.125), "left source 0: read failed: unplugged, reconnecting in 0.4 s");
  cam->opens = false;  // still unplugged: 0.5, then 1 s
  const auto attempts = stepUntil(s, *cam, 0.125, 2.0, &frames);
  EXPECT_EQ(attempts, (std::vector<double>{0.5, 1.5}));
  EXPECT_EQ(s.reconnects(), 3);
}

TEST(CameraSupervisor, AConnectionWithoutAFirstFrameIsGivenUpAfterTheOpenTimeout) {
  auto cam = std::make_shared<FakeCamera>();
  SourceSupervisor s("left source rtsp://cam/x", ptz::test::fakeFactory(cam),
                     SupervisorParams{2.0, 5.0, 0.5, 8.0});
  std::vector<CapturedFrame> frames;
  s.step(0.0, &frames);
  EXPECT_EQ(s.state(), State::kConnecting);
  EXPECT_EQ(s.problem(1.0), "");  // the first connection is not a problem yet
  s.step(5.0, &frames);
  EXPECT_EQ(s.state(), State::kConnecting);
  s.step(5.125, &frames);
  EXPECT_EQ(s.state(), State::kWaiting);
  EXPECT_EQ(s.problem(5.125),
            "left source rtsp://cam/x: no frame 5.1 s after opening, reconnecting in 0.5 s");
}

TEST(CameraSupervisor, TheEndOfAFileEndsTheSourceWithoutRetries) {
  auto cam = std::make_shared<FakeCamera>();
  SourceSupervisor s("left source left.avi", ptz::test::fakeFactory(cam), SupervisorParams{});
  std::vector<CapturedFrame> frames;
  for (int k = 0; k < 3; ++k) cam->push(k);
  cam->end_after_queue = true;
  stepUntil(s, *cam, 0.0, 30.0, &frames);
  EXPECT_EQ(frames.size(), 3u);
  EXPECT_EQ(s.state(), State::kEnded);
  EXPECT_EQ(cam->connections, 1);
  EXPECT_EQ(s.reconnects(), 0);
  EXPECT_EQ(s.problem(30.0), "");
  EXPECT_EQ(s.takeEvents(),
            (std::vector<std::string>{"left source left.avi: end of file after 3 frames"}));
}

TEST(CameraSupervisor, ASourceTheCallerPausesIsNotTakenForSilent) {
  auto cam = std::make_shared<FakeCamera>();
  SourceSupervisor s("left source left.avi", ptz::test::fakeFactory(cam), SupervisorParams{});
  std::vector<CapturedFrame> frames;
  for (int k = 0; k < 5; ++k) cam->push(k);
  s.step(0.0, &frames, 2);
  EXPECT_EQ(frames.size(), 2u);
  s.step(3.0, &frames, 0);  // no room for 3 s: still streaming
  EXPECT_EQ(s.state(), State::kStreaming);
  s.step(3.125, &frames);
  EXPECT_EQ(frames.size(), 5u);
  EXPECT_EQ(s.state(), State::kStreaming);
  s.step(5.25, &frames);  // really silent for 2.1 s
  EXPECT_EQ(s.state(), State::kWaiting);
}

TEST(CameraSupervisor, ARecordingWaitingForItsNextFrameHasNoTimeouts) {
  auto cam = std::make_shared<FakeCamera>();
  SourceSupervisor s("left source left.avi", ptz::test::fakeFactory(cam),
                     SupervisorParams{2.0, 5.0, 0.5, 8.0}, /*live=*/false);
  std::vector<CapturedFrame> frames;
  // The first frame is recorded 6 s after the other side's: longer than the open timeout.
  stepUntil(s, *cam, 0.0, 6.0, &frames);
  EXPECT_EQ(s.state(), State::kConnecting);
  cam->push(6'000'000);
  s.step(6.125, &frames);
  // Then a 3 s gap in the recording: longer than the silence timeout.
  stepUntil(s, *cam, 6.25, 9.125, &frames);
  EXPECT_EQ(s.state(), State::kStreaming);
  cam->push(9'125'000);
  cam->end_after_queue = true;
  s.step(9.25, &frames);
  EXPECT_EQ(frames.size(), 2u);
  EXPECT_EQ(s.state(), State::kEnded);
  EXPECT_EQ(cam->connections, 1);
  EXPECT_EQ(s.reconnects(), 0);
}
