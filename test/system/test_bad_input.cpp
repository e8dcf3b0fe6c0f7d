// Bad messages are dropped, counted and survived: ptz-detect and ptz-control as processes (in a
// private network namespace), fed by this test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>

#include "common/transport/transport.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "sim/simulator.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/rendered_frame.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

struct Outputs {
  std::map<int64_t, ptzstereo::object_pose_t> poses;     // by frame seq
  std::map<int64_t, ptzstereo::object_tracks_t> tracks;  // by frame seq
  std::vector<ptzstereo::ptz_setpoint_t> setpoints;
  std::vector<ptzstereo::control_state_t> control_states;
  std::map<std::string, std::map<std::string, int64_t>> counters;
  int64_t statuses = 0;

  void onPose(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::object_pose_t* m) {
    poses[m->frame_seq] = *m;
  }
  void onTracks(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::object_tracks_t* m) {
    tracks[m->frame_seq] = *m;
  }
  void onSetpoint(const lcm::ReceiveBuffer*, const std::string&,
                  const ptzstereo::ptz_setpoint_t* m) {
    setpoints.push_back(*m);
  }
  void onControlState(const lcm::ReceiveBuffer*, const std::string&,
                      const ptzstereo::control_state_t* m) {
    control_states.push_back(*m);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    ++statuses;
    auto& c = counters[m->process];
    c["up"] = 1;
    for (const auto& counter : m->counters) c[counter.name] = counter.value;
  }
  int64_t dropped(const std::string& process) {
    int64_t n = 0;
    for (const auto& [name, value] : counters[process]) {
      if (name.rfind("dropped_", 0) == 0) n += value;
    }
    return n;
  }
};

}  // namespace

TEST(BadInput, DetectDropsBadFramesCountsThemAndKeepsRunning) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Outputs out;
  lcm.subscribe("OBJECT_POSE", &Outputs::onPose, &out);
  lcm.subscribe("OBJECT_TRACKS", &Outputs::onTracks, &out);
  lcm.subscribe("PROCESS_STATUS_PTZ_DETECT", &Outputs::onStatus, &out);
  ChildProcess detect({PTZ_DETECT_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                       PTZ_SOURCE_DIR "/config/detect_default.yaml", "--status-period-s", "0.05"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-detect"]["up"] > 0; }, 20s));

  // Good frames, each sent when the one before is answered (well within the tracker's
  // track_tentative_max_gap_s of 0.25 s): the ball is an object in every one; its track is
  // confirmed by its third measurement (track_confirm_hits = 3), and only then is it the target.
  const ptzstereo::stereo_frame_t good = ptz::test::ballFrame(1);
  for (int64_t seq = 1; seq <= 3; ++seq) {
    ptz::test::publishNow(lcm, "STEREO_FRAME", ptz::test::ballFrame(seq));
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm, [&] { return out.poses.count(seq) > 0 && out.tracks.count(seq) > 0; }, 10s))
        << "no answer to good frame " << seq;
    ASSERT_EQ(out.poses[seq].num_objects, 1) << seq;
    EXPECT_EQ(out.poses[seq].objects[0].class_name, "red_ball") << seq;
    EXPECT_EQ(out.poses[seq].target_index, seq < 3 ? -1 : 0) << seq;
  }
  const ptzstereo::object_tracks_t& confirmed = out.tracks[3];
  ASSERT_EQ(confirmed.num_tracks, 1);
  EXPECT_EQ(confirmed.target_id, confirmed.tracks[0].id);
  EXPECT_EQ(confirmed.tracks[0].state, ptzstereo::object_track_t::STATE_CONFIRMED);
  EXPECT_EQ(confirmed.tracks[0].object_index, 0);

  std::vector<ptzstereo::stereo_frame_t> bad(4, good);
  bad[0].seq = 4;
  bad[0].left.encoding = 7;  // unknown encoding
  bad[1].seq = 5;
  bad[1].right.data.resize(1000);  // truncated
  bad[1].right.data_size = 1000;
  bad[2].seq = 6;
  bad[2].left.pan_rad = std::nan("");  // a non-finite pose
  bad[3].seq = 7;                      // not the rig's image size
  cv::Mat small(240, 320, CV_8UC3, cv::Scalar(0, 0, 200));
  bad[3].left = ptz::encodeImage(small, ptzstereo::image_t::ENCODING_RAW, 90);
  bad[3].right = bad[3].left;
  for (size_t i = 0; i < bad.size(); ++i) {
    ptz::test::publishNow(lcm, "STEREO_FRAME", bad[i]);
    // Wait until it is counted before the next (ptz-detect keeps only the newest frame).
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm, [&] { return out.dropped("ptz-detect") == static_cast<int64_t>(i + 1); }, 10s))
        << "bad frame " << i << " was not counted";
  }
  EXPECT_EQ(out.counters["ptz-detect"]["dropped_bad_image"], 3);
  EXPECT_EQ(out.counters["ptz-detect"]["dropped_size_mismatch"], 1);

  // A message that does not decode: the left image's data_size (after the fingerprint, utime,
  // publish_utime, seq and the image's 4+4+4+1+1+8+8+8 header bytes) says -1.
  std::vector<uint8_t> bytes(static_cast<size_t>(good.getEncodedSize()));
  good.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  std::fill_n(bytes.begin() + 32 + 38, 4, 0xFF);
  lcm.publish("STEREO_FRAME", bytes.data(), static_cast<unsigned>(bytes.size()));
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-detect"]["dropped_undecodable"] == 1; }, 10s))
      << "a malformed message was not counted (or took the process down)";

  ptzstereo::stereo_frame_t again = good;
  again.seq = 8;
  ptz::test::publishNow(lcm, "STEREO_FRAME", again);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.poses.count(8) > 0; }, 10s))
      << "ptz-detect stopped answering after bad frames";
  // The bad frames never reached the tracker: the confirmed track (which coasts up to
  // track_coast_s = 2 s unseen) is updated again and still the target.
  EXPECT_EQ(out.poses[8].target_index, 0);
  for (int64_t seq = 4; seq <= 7; ++seq) EXPECT_EQ(out.poses.count(seq), 0u) << seq;
  EXPECT_EQ(detect.stop(), 0);  // and it still stops cleanly
}

TEST(BadInput, ControlNeverTurnsABadTargetIntoASetpoint) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Outputs out;
  lcm.subscribe("PTZ_SETPOINT", &Outputs::onSetpoint, &out);
  lcm.subscribe("CONTROL_STATE", &Outputs::onControlState, &out);
  lcm.subscribe("PROCESS_STATUS_PTZ_CONTROL", &Outputs::onStatus, &out);
  ChildProcess control(
      {PTZ_CONTROL_BIN, "--lcm-url", ptz::test::kTestUrl, "--status-period-s", "0.05"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-control"]["up"] > 0; }, 20s));
  // Capture times 1 ms apart from now: the whole sequence lies well within lost_hold_s (0.5 s)
  // of the good message, whatever the machine's speed, so a lost target holds the setpoint.
  const int64_t t0_utime = ptz::wallUtime();
  constexpr int64_t kTargetId = 5;
  auto tracks = [&](int64_t seq, double x, double y, double z) {
    ptzstereo::object_tracks_t m{};
    m.utime = t0_utime + seq * 1000;
    m.frame_seq = seq;
    m.left_ptz = {0, 0, 1};
    m.right_ptz = {0, 0, 1};
    m.target_id = kTargetId;
    m.target_reason = "locked on track 5 (red_ball) by class";
    ptzstereo::object_track_t t{};
    t.id = kTargetId;
    t.class_name = "red_ball";
    t.state = ptzstereo::object_track_t::STATE_CONFIRMED;
    t.position_m[0] = x;
    t.position_m[1] = y;
    t.position_m[2] = z;
    t.radius_m = 0.1;
    t.object_index = 0;
    t.orientation_wxyz[0] = 1;
    m.tracks = {t};
    m.num_tracks = 1;
    return m;
  };
  const double nan = std::nan("");
  std::vector<ptzstereo::object_tracks_t> msgs = {
      tracks(1, 0.3, 0.0, 3.0),  // good: the heads turn right
      tracks(2, nan, 0.0, 3.0), tracks(3, 0.0, 0.0, 1e9), tracks(4, 0.0, 0.0, -3.0),
      tracks(5, 0.3, 0.0, 3.0), tracks(6, 0.3, 0.0, 3.0), tracks(7, 0.3, 0.0, 3.0),
      tracks(8, 0.3, 0.0, 3.0)};
  msgs[4].tracks[0].velocity_m_s[0] = nan;  // a non-finite velocity: implausible
  msgs[5].tracks[0].state = ptzstereo::object_track_t::STATE_TENTATIVE;  // not a target yet
  msgs[6].target_id = 7;                // an id none of the tracks has: no target
  msgs[7].left_ptz.pan_rad = INFINITY;  // a corrupt camera pose: dropped
  for (auto& m : msgs) {
    const size_t before = out.setpoints.size();
    const int64_t dropped_before = out.dropped("ptz-control");
    m.publish_utime = ptz::wallUtime();
    lcm.publish("OBJECT_TRACKS", &m);
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm,
        [&] {
          return out.setpoints.size() > before || out.dropped("ptz-control") > dropped_before;
        },
        10s));
  }
  // A message that does not decode: num_tracks says -1. It follows the fingerprint, utime,
  // publish_utime, frame_seq, the two heads' 3 doubles, target_id and target_reason (a 4-byte
  // length, the characters and a NUL).
  auto good = tracks(9, 0.3, 0.0, 3.0);
  good.publish_utime = ptz::wallUtime();
  std::vector<uint8_t> bytes(static_cast<size_t>(good.getEncodedSize()));
  good.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  const size_t num_tracks_at = 8 + 3 * 8 + 2 * 3 * 8 + 8 + 4 + good.target_reason.size() + 1;
  ASSERT_EQ(bytes[num_tracks_at + 3], 1) << "num_tracks is not where it was computed to be";
  std::fill_n(bytes.begin() + static_cast<std::ptrdiff_t>(num_tracks_at), 4, 0xFF);
  lcm.publish("OBJECT_TRACKS", bytes.data(), static_cast<unsigned>(bytes.size()));
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-control"]["dropped_undecodable"] == 1; }, 10s))
      << "a malformed message was not counted (or took the process down)";
  // One setpoint, and one control state, per message but none for the corrupt camera pose.
  ASSERT_EQ(out.setpoints.size(), 7u);
  ASSERT_EQ(out.control_states.size(), 7u);
  for (const auto& s : out.setpoints) {
    for (double v : {s.left.pan_rad, s.left.tilt_rad, s.left.zoom, s.right.pan_rad,
                     s.right.tilt_rad, s.right.zoom}) {
      EXPECT_TRUE(std::isfinite(v));
    }
  }
  EXPECT_GT(out.setpoints[0].left.pan_rad, 0.0);
  EXPECT_EQ(out.control_states[0].state, ptzstereo::control_state_t::STATE_TRACKING);
  EXPECT_EQ(out.control_states[0].target_id, kTargetId);
  // The bad targets held the setpoint of the good one.
  for (size_t i = 1; i < 7; ++i) {
    EXPECT_EQ(out.setpoints[i].frame_seq, static_cast<int64_t>(i + 1));
    EXPECT_DOUBLE_EQ(out.setpoints[i].left.pan_rad, out.setpoints[0].left.pan_rad) << i;
    EXPECT_EQ(out.control_states[i].state, ptzstereo::control_state_t::STATE_HOLDING) << i;
    EXPECT_EQ(out.control_states[i].target_id, -1) << i;
  }
  // Implausible: the NaN, the far, the behind position and the NaN velocity; the tentative
  // track is no target and no fault.
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-control"]["implausible_poses"] == 4; }, 5s));
  EXPECT_EQ(out.counters["ptz-control"]["target_not_in_tracks"], 1);
  EXPECT_EQ(out.counters["ptz-control"]["dropped_nonfinite_ptz"], 1);
  EXPECT_EQ(control.stop(), 0);  // still alive, and stops cleanly
}

namespace {
// Runs a command line with stderr to a file; returns the exit code and what it printed.
std::pair<int, std::string> runForError(const std::string& cmd) {
  const std::string err = std::string(::testing::TempDir()) + "/stderr.txt";
  const int status = std::system((cmd + " > /dev/null 2> " + err).c_str());
  std::ifstream in(err);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text};
}
}  // namespace

TEST(BadInput, MissingOrMalformedFilesStopTheProcessWithTheFileAndFieldNamed) {
  const std::string bad = std::string(::testing::TempDir()) + "/bad_detect.yaml";
  std::ofstream(bad) << "%YAML:1.0\n---\nclasses:\n  - { name: \"red\", hue_min_deg: 10.0 }\n";
  auto [code, text] = runForError(std::string(PTZ_DETECT_BIN) + " --config " + bad);
  EXPECT_EQ(code, 2);
  EXPECT_NE(text.find(bad), std::string::npos) << text;
  EXPECT_NE(text.find("hue_max_deg"), std::string::npos) << text;

  std::tie(code, text) = runForError(std::string(PTZ_DETECT_BIN) + " --config /nonexistent/x.yaml");
  EXPECT_EQ(code, 2);
  EXPECT_NE(text.find("/nonexistent/x.yaml"), std::string::npos) << text;

  std::tie(code, text) =
      runForError(std::string(PTZ_CONTROL_BIN) + " --rig-file /nonexistent/rig.yaml");
  EXPECT_EQ(code, 2);
  EXPECT_NE(text.find("/nonexistent/rig.yaml"), std::string::npos) << text;

  std::tie(code, text) = runForError(std::string(PTZ_CONTROL_BIN) + " --mode fancy");
  EXPECT_EQ(code, 2);
  EXPECT_NE(text.find("mode"), std::string::npos) << text;
}
