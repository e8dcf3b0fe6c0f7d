// ptz-view under Xvfb, on the simulator's frames with ptz-detect: the X screen (captured with
// ImageMagick's import) shows both images with the overlay where the detections say; the s key
// (sent with xdotool) saves the same picture; q quits.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <random>

#include "common/transport.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "tools/view/viewer.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

struct Listener {
  std::map<int64_t, ptzstereo::object_detections_t> detections;
  std::map<int64_t, ptzstereo::object_pose_t> poses;
  std::map<std::string, std::map<std::string, int64_t>> counters;
  int64_t last_frame_seq = -1;
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    last_frame_seq = std::max(last_frame_seq, m->seq);
  }
  void onDetections(const lcm::ReceiveBuffer*, const std::string&,
                    const ptzstereo::object_detections_t* m) {
    detections[m->frame_seq] = *m;
  }
  void onPose(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::object_pose_t* m) {
    poses[m->frame_seq] = *m;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    auto& c = counters[m->process];
    c["up"] = 1;
    for (const auto& counter : m->counters) c[counter.name] = counter.value;
  }
};

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Within a small distance of an overlay colour (lines are anti-aliased).
bool near(const cv::Vec3b& p, const cv::Scalar& c) {
  return std::abs(p[0] - c[0]) + std::abs(p[1] - c[1]) + std::abs(p[2] - c[2]) < 100;
}

}  // namespace

TEST(View, TheScreenShowsBothImagesWithTheOverlay) {
  // A display number of our own (the lock files live in the shared /tmp).
  std::mt19937 rng(std::random_device{}());
  int display = 0;
  do {
    display = 100 + static_cast<int>(rng() % 800);
  } while (exists("/tmp/.X" + std::to_string(display) + "-lock"));
  const std::string d = ":" + std::to_string(display);
  ChildProcess xvfb({"/usr/bin/Xvfb", d, "-screen", "0", "1400x800x24", "-nolisten", "tcp"});
  const auto x_deadline = std::chrono::steady_clock::now() + 20s;
  while (shell("DISPLAY=" + d + " xdotool getdisplaygeometry > /dev/null 2>&1") != 0) {
    ASSERT_LT(std::chrono::steady_clock::now(), x_deadline) << "Xvfb did not start";
    ASSERT_EQ(xvfb.wait(50ms), -1) << "Xvfb exited";
  }
  setenv("DISPLAY", d.c_str(), 1);

  lcm::LCM lcm(ptz::test::kTestUrl);
  Listener l;
  lcm.subscribe("OBJECT_DETECTIONS", &Listener::onDetections, &l);
  lcm.subscribe("OBJECT_POSE", &Listener::onPose, &l);
  lcm.subscribe("STEREO_FRAME", &Listener::onFrame, &l);
  lcm.subscribe("PROCESS_STATUS_.*", &Listener::onStatus, &l);
  const std::string shots = std::string(::testing::TempDir()) + "/view_shots";
  ::mkdir(shots.c_str(), 0755);
  ChildProcess detect({PTZ_DETECT_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                       PTZ_SOURCE_DIR "/config/detect_default.yaml"});
  // A frame waits for its detections (however slow ptz-detect is here) before it is drawn.
  ChildProcess view({PTZ_VIEW_BIN, "--lcm-url", ptz::test::kTestUrl, "--screenshot-dir", shots,
                     "--max-wait-s", "5"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-detect"]["up"] && l.counters["ptz-view"]["up"]; }, 30s));
  // The ball stands still, so any frame drawn shows it where its detections say.
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                    PTZ_SOURCE_DIR "/config/sim_paper.yaml", "--clock", "realtime", "--encoding",
                    "jpeg", "--frames", "45"});
  ptz::test::handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0; }, 60s);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-view"]["frames_drawn"] >= 5; }, 10s))
      << "ptz-view drew " << l.counters["ptz-view"]["frames_drawn"] << " frames";
  // Nothing more will be drawn once the viewer shows the simulator's last frame: detection
  // (a queue of one) always answers the newest frame, and the viewer waits for its answer.
  ASSERT_GE(l.last_frame_seq, 0);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-view"]["last_frame_drawn"] >= l.last_frame_seq; }, 15s))
      << "ptz-view drew frame " << l.counters["ptz-view"]["last_frame_drawn"]
      << " last; the simulator's last was " << l.last_frame_seq;
  const int64_t seq = l.counters["ptz-view"]["last_frame_drawn"];

  // s saves what is on the screen; then the screen itself.
  ASSERT_EQ(shell("xdotool search --name ptz-view key s"), 0);
  const std::string saved = shots + "/ptz-view-" + std::to_string(seq) + ".png";
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-view"]["screenshots"] >= 1; }, 10s))
      << "the s key saved nothing";
  const std::string root = shots + "/root.png";
  ASSERT_EQ(shell("import -window root " + root), 0);
  const cv::Mat canvas = cv::imread(saved), screen = cv::imread(root);
  ASSERT_FALSE(canvas.empty()) << saved;
  ASSERT_FALSE(screen.empty()) << root;
  ASSERT_EQ(canvas.cols, 2 * 640);
  ASSERT_EQ(canvas.rows, 480 + ptz::tools::kPanelHeightPx);

  // Where the window put the picture: the exact match of the saved one.
  cv::Mat score;
  cv::matchTemplate(screen, canvas, score, cv::TM_SQDIFF);
  double best = 0;
  cv::Point at;
  cv::minMaxLoc(score, &best, nullptr, &at);
  EXPECT_LT(best / canvas.total(), 1.0) << "the screen does not show the saved picture";
  const cv::Mat shown = screen(cv::Rect(at, canvas.size()));

  // The overlay where the messages say: centre crosses, the target's outline in both images,
  // the epipolar line through the right image's target.
  // The vertical arms (the target's epipolar line may cross the horizontal ones).
  EXPECT_TRUE(near(shown.at<cv::Vec3b>(240 - 10, 320), ptz::tools::kCentreColour));
  EXPECT_TRUE(near(shown.at<cv::Vec3b>(240 - 10, 640 + 320), ptz::tools::kCentreColour));
  ASSERT_TRUE(l.detections.count(seq) && l.poses.count(seq)) << "frame " << seq;
  const auto& pose = l.poses[seq];
  ASSERT_GE(pose.target_index, 0);
  const auto& obj = pose.objects[static_cast<size_t>(pose.target_index)];
  const auto& left = l.detections[seq].left[static_cast<size_t>(obj.left_index)];
  const auto& right = l.detections[seq].right[static_cast<size_t>(obj.right_index)];
  auto onOutline = [&](const ptzstereo::detection_2d_t& det, int x_offset) {
    const int r = static_cast<int>(std::lround(std::sqrt(det.area_px2 / M_PI)));
    const int x = x_offset + static_cast<int>(std::lround(det.centroid_x_px));
    const int y = static_cast<int>(std::lround(det.centroid_y_px));
    // The 2 px wide circle crosses the column through the centroid at y - r (the row through
    // it carries the epipolar line).
    int hits = 0;
    for (int dy = -2; dy <= 2; ++dy) {
      const int row = std::clamp(y - r + dy, 0, 479);
      hits += near(shown.at<cv::Vec3b>(row, std::clamp(x, 0, 1279)), ptz::tools::kTargetColour);
    }
    return hits;
  };
  EXPECT_GE(onOutline(left, 0), 1);
  EXPECT_GE(onOutline(right, 640), 1);
  int green = 0;
  const int ex = 640 + static_cast<int>(right.centroid_x_px) +
                 static_cast<int>(std::sqrt(right.area_px2 / M_PI)) + 20;
  ASSERT_LT(ex, 1280) << "the target is too near the right edge for this check";
  for (int dy = -4; dy <= 4; ++dy) {
    const int row = std::clamp(static_cast<int>(right.centroid_y_px) + dy, 0, 479);
    const cv::Vec3b p = shown.at<cv::Vec3b>(row, ex);
    green += near(p, ptz::tools::kEpipolarColour);
  }
  EXPECT_GE(green, 1) << "no epipolar line beside the right image's target";

  // q quits cleanly.
  ASSERT_EQ(shell("xdotool search --name ptz-view key q"), 0);
  EXPECT_EQ(view.wait(10s), 0);
}
