// Process replay: the committed log of a 2 s closed-loop run (JPEG frames) replayed through a
// fresh ptz-detect gives bit-identical poses and tracks; a change in perception, or in the
// tracker alone, is noticed.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <iterator>
#include <map>
#include <string>

#include "common/transport/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "support/child_process.hpp"
#include "tools/logs/log_reader.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

const std::string kFixture = PTZ_SOURCE_DIR "/test/fixtures/closed_loop_2s.lcmlog";
constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";

template <typename Message>
std::map<int64_t, Message> read(const std::string& path, const std::string& channel,
                                int64_t* frames) {
  std::map<int64_t, Message> out;
  ptz::tools::LogReader reader(path);
  *frames = 0;
  while (const lcm::LogEvent* ev = reader.next()) {
    if (ev->channel == "STEREO_FRAME") ++*frames;
    Message m;
    if (ev->channel == channel && m.decode(ev->data, 0, ev->datalen) >= 0) out[m.frame_seq] = m;
  }
  EXPECT_TRUE(reader.breaks().empty()) << reader.describeBreaks();
  return out;
}

std::map<int64_t, ptzstereo::object_pose_t> poses(const std::string& path, int64_t* frames) {
  return read<ptzstereo::object_pose_t>(path, "OBJECT_POSE", frames);
}

std::map<int64_t, ptzstereo::object_tracks_t> tracks(const std::string& path) {
  int64_t frames = 0;
  return read<ptzstereo::object_tracks_t>(path, "OBJECT_TRACKS", &frames);
}

// Both messages' bytes, publish time aside.
template <typename Message>
std::vector<uint8_t> canonical(Message m) {
  m.publish_utime = 0;
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// Runs ptz-detect (with extra flags) and ptz-replay --check; returns replay's exit code.
int replay(const std::vector<std::string>& detect_flags, const std::string& out) {
  std::vector<std::string> detect = {PTZ_DETECT_BIN, "--lcm-url", kUrl, "--config",
                                     PTZ_SOURCE_DIR "/config/detect_default.yaml"};
  detect.insert(detect.end(), detect_flags.begin(), detect_flags.end());
  ChildProcess d(detect);
  ChildProcess r({PTZ_REPLAY_BIN, "--lcm-url", kUrl, "--log", kFixture, "--out", out, "--check",
                  "true", "--timeout-s", "10"});
  return r.wait(120s);
}

}  // namespace

TEST(Replay, TheCommittedRunReplaysBitIdentically) {
  int64_t frames = 0;
  const auto logged = poses(kFixture, &frames);
  ASSERT_GE(frames, 50);
  ASSERT_EQ(static_cast<int64_t>(logged.size()), frames) << "the fixture should answer every frame";
  const std::string out = std::string(::testing::TempDir()) + "/replayed.lcmlog";
  EXPECT_EQ(replay({}, out), 0);
  int64_t none = 0;
  const auto replayed = poses(out, &none);
  ASSERT_EQ(replayed.size(), logged.size());
  int64_t targets = 0;
  for (const auto& [seq, l] : logged) {
    const auto& r = replayed.at(seq);
    ASSERT_EQ(r.num_objects, l.num_objects) << "frame " << seq;
    EXPECT_EQ(r.target_index, l.target_index) << "frame " << seq;
    targets += l.target_index >= 0;
    for (size_t i = 0; i < l.objects.size(); ++i) {
      EXPECT_EQ(std::memcmp(r.objects[i].position_m, l.objects[i].position_m,
                            sizeof(l.objects[i].position_m)),
                0)
          << "frame " << seq << " object " << i;
    }
  }
  // The ball is the target in every frame but the first two (its track is confirmed by its third
  // measurement, track_confirm_hits = 3): the comparison means something.
  EXPECT_EQ(targets, frames - 2);
  EXPECT_LT(logged.begin()->second.target_index, 0);
  EXPECT_LT(std::next(logged.begin())->second.target_index, 0);
  // The tracks of every frame too: the ball's one track, its velocity and covariance.
  const auto logged_tracks = tracks(kFixture), replayed_tracks = tracks(out);
  ASSERT_EQ(static_cast<int64_t>(logged_tracks.size()), frames);
  ASSERT_EQ(replayed_tracks.size(), logged_tracks.size());
  for (const auto& [seq, l] : logged_tracks) {
    EXPECT_EQ(canonical(replayed_tracks.at(seq)), canonical(l)) << "frame " << seq;
  }
  EXPECT_GE(logged_tracks.rbegin()->second.num_tracks, 1);
}

TEST(Replay, AChangeInTheTrackerAloneIsNoticed) {
  // Ten times the jerk density: other velocities and covariances, the same measured positions
  // and targets (what else a pose says may follow the tracks: which regions are trusted).
  const std::string out = std::string(::testing::TempDir()) + "/tracker_changed.lcmlog";
  EXPECT_EQ(replay({"--track-jerk-psd-m2-s5", "50"}, out), 1);
  int64_t frames = 0;
  const auto logged = poses(kFixture, &frames), replayed = poses(out, &frames);
  ASSERT_EQ(replayed.size(), logged.size());
  for (const auto& [seq, l] : logged) {
    const auto& r = replayed.at(seq);
    ASSERT_EQ(r.num_objects, l.num_objects) << "frame " << seq;
    EXPECT_EQ(r.target_index, l.target_index) << "frame " << seq;
    for (size_t i = 0; i < l.objects.size(); ++i) {
      EXPECT_EQ(std::memcmp(r.objects[i].position_m, l.objects[i].position_m,
                            sizeof(l.objects[i].position_m)),
                0)
          << "frame " << seq << " object " << i;
    }
  }
  const auto logged_tracks = tracks(kFixture), replayed_tracks = tracks(out);
  ASSERT_EQ(replayed_tracks.size(), logged_tracks.size());
  int64_t different = 0;
  for (const auto& [seq, l] : logged_tracks) {
    different += canonical(replayed_tracks.at(seq)) != canonical(l);
  }
  EXPECT_GE(different, frames / 2);
}

TEST(Replay, AChangeInPerceptionIsNoticed) {
  // A larger morphology kernel moves centroids by fractions of a pixel: not identical (exit 1;
  // unanswered frames would be exit 3).
  const std::string out = std::string(::testing::TempDir()) + "/changed.lcmlog";
  EXPECT_EQ(replay({"--morph-size-px", "5"}, out), 1);
}

TEST(Replay, TheScriptReplaysAndChecks) {
  ChildProcess script({"/usr/bin/env", "PTZ_BUILD=" PTZ_BUILD_DIR, PTZ_SOURCE_DIR "/scripts/replay",
                       kFixture, "--check"});
  EXPECT_EQ(script.wait(120s), 0);
}
