// ptz-depth as a process (in a private network namespace): clouds for ptz-sim's frames with the
// frame's utime and seq, PCD files, the horopter on the OBJECT_POSE target, and bad input dropped,
// counted and survived.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>

#include "common/transport/transport.hpp"
#include "perception/depth/depth.hpp"
#include "ptzstereo/image_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/point_cloud_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/rendered_frame.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

struct Outputs {
  std::map<int64_t, int64_t> frame_utime;  // seq -> utime of STEREO_FRAME
  std::vector<ptzstereo::point_cloud_t> clouds;
  int64_t disparity_images = 0;
  std::map<std::string, int64_t> counters;
  int8_t state = 0;
  std::string message;
  bool up = false;

  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    frame_utime[m->seq] = m->utime;
  }
  void onCloud(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::point_cloud_t* m) {
    clouds.push_back(*m);
  }
  void onDisparity(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::image_t*) {
    ++disparity_images;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    up = true;
    state = m->state;
    message = m->message;
    for (const auto& c : m->counters) counters[c.name] = c.value;
  }
};

std::vector<std::string> depthCommand(const std::vector<std::string>& extra) {
  std::vector<std::string> cmd = {PTZ_DEPTH_BIN, "--lcm-url", ptz::test::kTestUrl,
                                  "--status-period-s", "0.1"};
  cmd.insert(cmd.end(), extra.begin(), extra.end());
  return cmd;
}

void subscribeAll(lcm::LCM& lcm, Outputs* out) {
  lcm.subscribe("STEREO_FRAME", &Outputs::onFrame, out);
  lcm.subscribe("POINT_CLOUD", &Outputs::onCloud, out);
  lcm.subscribe("DISPARITY_IMAGE", &Outputs::onDisparity, out);
  lcm.subscribe("PROCESS_STATUS_PTZ_DEPTH", &Outputs::onStatus, out);
}

}  // namespace

TEST(DepthProcess, PublishesCloudsOfSimulatorFramesAndWritesPcd) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Outputs out;
  subscribeAll(lcm, &out);
  const std::string pcd = ::testing::TempDir() + "ptz_depth_{seq}.pcd";
  ChildProcess depth(
      depthCommand({"--pcd-path", pcd, "--pcd-every-n", "1", "--publish-disparity", "true"}));
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.up; }, 20s))
      << "ptz-depth did not come up";
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                    PTZ_SOURCE_DIR "/config/sim_default.yaml", "--frames", "60", "--clock",
                    "realtime"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0 && out.clouds.size() >= 5; }, 60s));
  // Everything of the last frame arrived: clouds, disparity images and the counters agree.
  const auto n = [&] { return static_cast<int64_t>(out.clouds.size()); };
  EXPECT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] {
        return out.counters["frames_processed"] == n() && out.counters["pcd_written"] == n() &&
               out.disparity_images == n();
      },
      10s));
  for (const auto& c : out.clouds) {
    ASSERT_EQ(out.frame_utime.count(c.frame_seq), 1u) << "cloud of an unknown frame";
    EXPECT_EQ(c.utime, out.frame_utime[c.frame_seq]);
    EXPECT_EQ(c.frame_id, "head");
    EXPECT_GT(c.width * c.height, 1000);
    EXPECT_EQ(c.data_size, c.width * c.height * c.point_step);
    EXPECT_GE(c.publish_utime, c.utime);
  }
  // Every cloud went to its own PCD file.
  std::string first = pcd;
  first.replace(first.find("{seq}"), 5, std::to_string(out.clouds.front().frame_seq));
  std::ifstream in(first);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("# .PCD", 0), 0u) << first;
  for (const auto& c : out.clouds) {
    std::string path = pcd;
    std::remove(path.replace(path.find("{seq}"), 5, std::to_string(c.frame_seq)).c_str());
  }
  EXPECT_EQ(depth.stop(), 0);
}

TEST(DepthProcess, SkipsUnknownGeometryAndBadFramesSurvivesAnUnwritablePcdPath) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Outputs out;
  subscribeAll(lcm, &out);
  ChildProcess depth(depthCommand({"--pcd-path", "/nonexistent-dir/cloud.pcd"}));
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.up; }, 20s));
  ptz::sim::Scene scene;
  scene.backdrop_distance_m = 5.0;
  const ptzstereo::stereo_frame_t good = ptz::test::renderedFrame(scene, 1);
  std::vector<ptzstereo::stereo_frame_t> bad(4, good);
  bad[0].seq = 2;
  bad[0].right.zoom = 12;  // the default rig's table ends at 10
  bad[1].seq = 3;
  bad[1].left.zoom = 0.5;  // and starts at 1
  bad[2].seq = 4;
  bad[2].left.pan_rad = std::nan("");  // decodeImage refuses it
  bad[3].seq = 5;
  bad[3].left.data.resize(100);  // truncated
  bad[3].left.data_size = 100;
  const int64_t unknown_after[] = {1, 2, 2, 2}, bad_image_after[] = {0, 0, 1, 2};
  for (size_t i = 0; i < bad.size(); ++i) {
    lcm.publish("STEREO_FRAME", &bad[i]);
    // Counted before the next is sent (ptz-depth keeps only the newest frame).
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm,
        [&] {
          return out.counters["dropped_unknown_geometry"] == unknown_after[i] &&
                 out.counters["dropped_bad_image"] == bad_image_after[i];
        },
        10s))
        << "bad frame " << i << " was not counted";
  }
  EXPECT_TRUE(out.clouds.empty()) << "a cloud from a frame of unknown geometry";
  // Still running: a good frame gives a cloud; the PCD it cannot write is a warning.
  lcm.publish("STEREO_FRAME", &good);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return !out.clouds.empty() && out.counters["pcd_write_errors"] == 1; }, 20s));
  EXPECT_EQ(out.clouds.front().frame_seq, 1);
  EXPECT_EQ(out.state, ptzstereo::process_status_t::STATE_WARN);
  EXPECT_NE(out.message.find("/nonexistent-dir/cloud.pcd"), std::string::npos) << out.message;
  EXPECT_EQ(depth.stop(), 0);
}

TEST(DepthProcess, CentresTheSearchRangeOnTheObjectPoseTarget) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Outputs out;
  subscribeAll(lcm, &out);
  ChildProcess depth(depthCommand({}));
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return out.up; }, 20s));
  ptz::sim::Scene scene;
  scene.backdrop_distance_m = 5.0;
  const ptzstereo::stereo_frame_t frame = ptz::test::renderedFrame(scene, 1);
  ptzstereo::object_pose_t pose{};
  pose.utime = frame.utime;
  pose.frame_seq = frame.seq;
  ptzstereo::object_3d_t target{};
  target.class_name = "red_ball";
  target.position_m[0] = 0.2;
  target.position_m[1] = 0.1;
  target.position_m[2] = 3.0;
  pose.objects = {target};
  pose.num_objects = 1;
  pose.target_index = 0;
  lcm.publish("OBJECT_POSE", &pose);
  lcm.publish("STEREO_FRAME", &frame);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return !out.clouds.empty() && out.counters["frames_processed"] == 1; }, 20s));
  // The range is 64 wide (the default) and centred on the target's disparity at this geometry.
  ptz::perception::Rectifier rectifier(ptz::StereoRig::makeDefault());
  std::string why;
  ASSERT_TRUE(rectifier.update({0, 0, 1}, {0, 0, 1}, &why));
  const double d = rectifier.current().disparityOf({0.2, 0.1, 3.0});
  EXPECT_EQ(out.counters["min_disparity_px"], static_cast<int64_t>(std::floor(d)) - 32);
  EXPECT_EQ(out.counters["frames_following_target"], 1);
  EXPECT_EQ(depth.stop(), 0);
}
