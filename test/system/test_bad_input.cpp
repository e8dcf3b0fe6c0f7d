// Bad messages are dropped, counted and survived: ptz-detect and ptz-control as processes (in a
// private network namespace), fed by this test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>

#include "common/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
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
  std::map<int64_t, ptzstereo::object_pose_t> poses;  // by frame seq
  std::vector<ptzstereo::ptz_setpoint_t> setpoints;
  std::map<std::string, std::map<std::string, int64_t>> counters;
  int64_t statuses = 0;

  void onPose(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::object_pose_t* m) {
    poses[m->frame_seq] = *m;
  }
  void onSetpoint(const lcm::ReceiveBuffer*, const std::string&,
                  const ptzstereo::ptz_setpoint_t* m) {
    setpoints.push_back(*m);
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
  lcm.subscribe("PROCESS_STATUS_PTZ_DETECT", &Outputs::onStatus, &out);
  ChildProcess detect({PTZ_DETECT_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                       PTZ_SOURCE_DIR "/config/detect_default.yaml", "--status-period-s", "0.05"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-detect"]["up"] > 0; }, 20s));

  const ptzstereo::stereo_frame_t good = ptz::test::ballFrame(1);
  ptz::test::publishNow(lcm, "STEREO_FRAME", good);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.poses.count(1) > 0; }, 10s));
  EXPECT_GE(out.poses[1].target_index, 0);

  std::vector<ptzstereo::stereo_frame_t> bad(4, good);
  bad[0].seq = 2;
  bad[0].left.encoding = 7;  // unknown encoding
  bad[1].seq = 3;
  bad[1].right.data.resize(1000);  // truncated
  bad[1].right.data_size = 1000;
  bad[2].seq = 4;
  bad[2].left.pan_rad = std::nan("");  // a non-finite pose
  bad[3].seq = 5;                      // not the rig's image size
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
  again.seq = 6;
  ptz::test::publishNow(lcm, "STEREO_FRAME", again);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.poses.count(6) > 0; }, 10s))
      << "ptz-detect stopped answering after bad frames";
  for (int64_t seq = 2; seq <= 5; ++seq) EXPECT_EQ(out.poses.count(seq), 0u) << seq;
  EXPECT_EQ(detect.stop(), 0);  // and it still stops cleanly
}

TEST(BadInput, ControlNeverTurnsABadPoseIntoASetpoint) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Outputs out;
  lcm.subscribe("PTZ_SETPOINT", &Outputs::onSetpoint, &out);
  lcm.subscribe("PROCESS_STATUS_PTZ_CONTROL", &Outputs::onStatus, &out);
  ChildProcess control(
      {PTZ_CONTROL_BIN, "--lcm-url", ptz::test::kTestUrl, "--status-period-s", "0.05"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-control"]["up"] > 0; }, 20s));
  auto pose = [](int64_t seq, double x, double y, double z) {
    ptzstereo::object_pose_t p{};
    p.utime = ptz::wallUtime();
    p.frame_seq = seq;
    p.left_ptz = {0, 0, 1};
    p.right_ptz = {0, 0, 1};
    ptzstereo::object_3d_t o{};
    o.class_name = "red_ball";
    o.position_m[0] = x;
    o.position_m[1] = y;
    o.position_m[2] = z;
    o.radius_m = 0.1;
    p.objects = {o};
    p.num_objects = 1;
    p.target_index = 0;
    return p;
  };
  const double nan = std::nan("");
  std::vector<ptzstereo::object_pose_t> poses = {
      pose(1, 0.3, 0.0, 3.0),  // good: the heads turn right
      pose(2, nan, 0.0, 3.0), pose(3, 0.0, 0.0, 1e9), pose(4, 0.0, 0.0, -3.0),
      pose(5, 0.3, 0.0, 3.0)};
  poses.push_back(pose(6, 0.3, 0.0, 3.0));
  poses.back().left_ptz.pan_rad = INFINITY;  // a corrupt camera pose: dropped
  poses[4].target_index = 7;                 // an index beyond the objects: no target
  for (const auto& p : poses) {
    const size_t before = out.setpoints.size();
    const int64_t dropped_before = out.dropped("ptz-control");
    ptz::test::publishNow(lcm, "OBJECT_POSE", p);
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm,
        [&] {
          return out.setpoints.size() > before || out.dropped("ptz-control") > dropped_before;
        },
        10s));
  }
  // A message that does not decode: num_objects (after 8 + 8 + 8 + 8 + 24 + 24 + 4 bytes) says -1.
  const auto good = pose(7, 0.3, 0.0, 3.0);
  std::vector<uint8_t> bytes(static_cast<size_t>(good.getEncodedSize()));
  good.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  std::fill_n(bytes.begin() + 84, 4, 0xFF);
  lcm.publish("OBJECT_POSE", bytes.data(), static_cast<unsigned>(bytes.size()));
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-control"]["dropped_undecodable"] == 1; }, 10s))
      << "a malformed message was not counted (or took the process down)";
  ASSERT_EQ(out.setpoints.size(), 5u);  // one per pose, but none for the corrupt camera pose
  for (const auto& s : out.setpoints) {
    for (double v : {s.left.pan_rad, s.left.tilt_rad, s.left.zoom, s.right.pan_rad,
                     s.right.tilt_rad, s.right.zoom}) {
      EXPECT_TRUE(std::isfinite(v));
    }
  }
  EXPECT_GT(out.setpoints[0].left.pan_rad, 0.0);
  // The implausible poses held the setpoint of the good one.
  for (size_t i = 1; i < 5; ++i) {
    EXPECT_DOUBLE_EQ(out.setpoints[i].left.pan_rad, out.setpoints[0].left.pan_rad) << i;
  }
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.counters["ptz-control"]["implausible_poses"] == 3; }, 5s));
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
