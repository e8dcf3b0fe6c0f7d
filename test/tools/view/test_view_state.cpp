// ptz-view's bookkeeping with known answers: a frame is drawn once its detections and pose are
// in or after max_wait, a newer frame replaces a waiting one, paused frames are not kept (all
// counted), and bogus frame_seqs cannot grow what is kept.
#include <gtest/gtest.h>

#include "tools/view/view_state.hpp"

using ptz::tools::ViewState;

namespace {

ptzstereo::stereo_frame_t frame(int64_t seq) {
  ptzstereo::stereo_frame_t m{};
  m.seq = seq;
  m.left.pan_rad = 0.25;
  return m;
}
ptzstereo::object_detections_t detections(int64_t seq) {
  ptzstereo::object_detections_t m{};
  m.frame_seq = seq;
  return m;
}
ptzstereo::object_pose_t pose(int64_t seq) {
  ptzstereo::object_pose_t m{};
  m.frame_seq = seq;
  return m;
}

}  // namespace

TEST(ViewKeeping, AFrameIsReadyOnceItsDetectionsAndPoseAreInOrAfterMaxWait) {
  ViewState state(200'000);
  state.onFrame(frame(5), 1'000'000, false);
  EXPECT_EQ(state.ready(1'000'000), nullptr);
  state.onDetections(detections(5));
  EXPECT_EQ(state.ready(1'000'000), nullptr);
  state.onPose(pose(5));
  const ptzstereo::stereo_frame_t* ready = state.ready(1'000'000);
  ASSERT_NE(ready, nullptr);
  EXPECT_EQ(ready->seq, 5);
  const auto in = state.input(1'000'000, false);
  EXPECT_EQ(in.seq, 5);
  EXPECT_DOUBLE_EQ(in.left_ptz.pan_rad, 0.25);
  EXPECT_TRUE(in.detections && in.pose);
  EXPECT_FALSE(in.tracks);
  EXPECT_DOUBLE_EQ(in.drawn_rate_hz, 1);
  state.done(true, 1'000'000);
  EXPECT_EQ(state.keptForFrames(), 0u);
  EXPECT_EQ(state.ready(2'000'000), nullptr);

  // Without its detections: after max_wait.
  state.onFrame(frame(6), 2'000'000, false);
  EXPECT_EQ(state.ready(2'199'999), nullptr);
  EXPECT_NE(state.ready(2'200'000), nullptr);
  EXPECT_EQ(state.framesNotDrawn(), 0);
}

TEST(ViewKeeping, ANewerFrameReplacesAWaitingOneAndPausedFramesAreNotKept) {
  ViewState state(200'000);
  state.onFrame(frame(1), 0, false);
  state.onFrame(frame(2), 10'000, false);
  EXPECT_EQ(state.framesNotDrawn(), 1);
  EXPECT_EQ(state.ready(300'000)->seq, 2);
  state.done(false, 300'000);
  state.onDetections(detections(3));
  state.onFrame(frame(3), 400'000, /*paused=*/true);
  EXPECT_EQ(state.framesNotDrawn(), 2);
  EXPECT_EQ(state.ready(10'000'000), nullptr);
  EXPECT_EQ(state.keptForFrames(), 0u);  // frame 3's detections forgotten with it
}

TEST(ViewKeeping, BogusFrameSeqsCannotGrowWhatIsKept) {
  ViewState state(200'000);
  state.onFrame(frame(100), 0, false);
  for (int64_t i = 0; i < 1000; ++i) state.onDetections(detections(i * 7919 - 3'000'000));
  state.onDetections(detections(100));
  EXPECT_LE(state.keptForFrames(), ViewState::kKept);
  state.onPose(pose(100));
  EXPECT_TRUE(state.input(0, false).detections.has_value());  // the near one was kept
}
