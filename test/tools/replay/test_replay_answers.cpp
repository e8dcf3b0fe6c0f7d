// ptz-replay's verdict on answers made here: a reply identical but for publish_utime counts as
// identical, a moved object as different (its largest change said), a reply to a frame not in
// the log as not logged; and the exit codes that follow.
#include <gtest/gtest.h>

#include "tools/logs/log_reader.hpp"
#include "tools/replay/replay_answers.hpp"

namespace {

ptzstereo::object_pose_t pose(int64_t seq, double x_m) {
  ptzstereo::object_pose_t m{};
  m.frame_seq = seq;
  m.utime = 100 + seq;
  m.target_index = 0;
  m.num_objects = 1;
  m.objects.resize(1);
  m.objects[0].position_m[0] = x_m;
  return m;
}

// p as ptz-detect answers it: encoded, with another publish time.
void reply(ptz::tools::Answers<ptzstereo::object_pose_t>* poses, ptzstereo::object_pose_t p) {
  p.publish_utime = 999'999;
  const auto bytes = ptz::tools::encoded(p);
  poses->onReply(bytes.data(), bytes.size());
}

}  // namespace

TEST(ReplayAnswers, IdenticalDifferentAndNotLoggedAreToldApart) {
  ptz::tools::Answers<ptzstereo::object_pose_t> poses("pose");
  ptz::tools::Answers<ptzstereo::object_tracks_t> tracks("tracks");
  for (int64_t seq : {1, 2}) poses.logged[seq] = pose(seq, 1.0);
  reply(&poses, pose(1, 1.0));   // identical
  reply(&poses, pose(2, 1.25));  // moved 0.25 m
  reply(&poses, pose(3, 1.0));   // not in the log
  for (int64_t seq : {1, 2, 3}) ASSERT_NE(poses.take(seq, 100 + seq), nullptr) << seq;
  EXPECT_EQ(poses.take(4, 104), nullptr);
  poses.compare();
  EXPECT_EQ(poses.identical, 1);
  EXPECT_EQ(poses.different, 1);
  EXPECT_EQ(poses.not_logged, 1);
  EXPECT_DOUBLE_EQ(ptz::tools::largestPositionChange(pose(2, 1.0), pose(2, 1.25)), 0.25);

  ptz::tools::ReplayTally tally;
  tally.frames = 3;
  EXPECT_EQ(ptz::tools::replayExitCode(false, tally, poses, tracks), ptz::tools::log_exit::kOk);
  EXPECT_EQ(ptz::tools::replayExitCode(true, tally, poses, tracks), ptz::tools::log_exit::kVerdict);
  tally.unanswered = 1;
  EXPECT_EQ(ptz::tools::replayExitCode(false, tally, poses, tracks),
            ptz::tools::log_exit::kUnanswered);
  EXPECT_EQ(ptz::tools::replaySummary(tally, poses, tracks),
            "replayed 3 frames: 1 poses identical to the log, 1 different, 1 without a logged "
            "pose; 0 tracks identical, 0 different, 0 without logged tracks; 1 frames "
            "unanswered\n");
}

TEST(ReplayAnswers, AnUndecodableReplyIsIgnored) {
  ptz::tools::Answers<ptzstereo::object_pose_t> poses("pose");
  const uint8_t garbage[] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  poses.onReply(garbage, sizeof garbage);
  EXPECT_TRUE(poses.replies.empty());
}
