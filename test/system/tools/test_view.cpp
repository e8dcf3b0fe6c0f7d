// ptz-view under Xvfb, on the simulator's frames with ptz-detect: the X screen (captured with
// ImageMagick's import) shows both images with the overlay where the detections say; the s key
// (sent with xdotool) saves the same picture; q quits. On a frame of our own with two tracks: each
// drawn where it projects, the controller's state in the panel, and a mouse click (xdotool) on
// one asks for it on TARGET_SELECT. And the drawing and the click mapping without a window.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <random>

#include "common/transport/transport.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"
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
  std::vector<ptzstereo::target_select_t> selects;
  int64_t last_frame_seq = -1;
  // The detections, poses, frames and statuses on lcm.
  void listen(lcm::LCM& lcm) {
    lcm.subscribe("OBJECT_DETECTIONS", &Listener::onDetections, this);
    lcm.subscribe("OBJECT_POSE", &Listener::onPose, this);
    lcm.subscribe("STEREO_FRAME", &Listener::onFrame, this);
    lcm.subscribe("PROCESS_STATUS_.*", &Listener::onStatus, this);
  }
  void onSelect(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::target_select_t* m) {
    selects.push_back(*m);
  }
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

std::vector<uint8_t> encoded(const ptzstereo::target_select_t& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// An X server of our own (a display number nobody holds: the lock files live in the shared
// /tmp), DISPLAY set to it.
void startX(std::unique_ptr<ChildProcess>* xvfb) {
  std::mt19937 rng(std::random_device{}());
  int display = 0;
  do {
    display = 100 + static_cast<int>(rng() % 800);
  } while (exists("/tmp/.X" + std::to_string(display) + "-lock"));
  const std::string d = ":" + std::to_string(display);
  *xvfb = std::make_unique<ChildProcess>(std::vector<std::string>{
      "/usr/bin/Xvfb", d, "-screen", "0", "1400x800x24", "-nolisten", "tcp"});
  const auto x_deadline = std::chrono::steady_clock::now() + 20s;
  while (shell("DISPLAY=" + d + " xdotool getdisplaygeometry > /dev/null 2>&1") != 0) {
    ASSERT_LT(std::chrono::steady_clock::now(), x_deadline) << "Xvfb did not start";
    ASSERT_EQ((*xvfb)->wait(50ms), -1) << "Xvfb exited";
  }
  setenv("DISPLAY", d.c_str(), 1);
}

// ptz-detect and ptz-view (view_args after its URL) on the simulator's frames, both up, and a
// fresh folder for the screenshots.
struct DetectAndView {
  std::string shots;
  std::unique_ptr<ChildProcess> detect, view;
};
void startDetectAndView(lcm::LCM& lcm, Listener& l, const std::string& shots_name,
                        std::vector<std::string> view_args, DetectAndView* out) {
  out->shots = std::string(::testing::TempDir()) + "/" + shots_name;
  shell("rm -rf '" + out->shots + "'");
  ::mkdir(out->shots.c_str(), 0755);
  out->detect = std::make_unique<ChildProcess>(
      std::vector<std::string>{PTZ_DETECT_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                               PTZ_SOURCE_DIR "/config/detect_default.yaml"});
  std::vector<std::string> view = {PTZ_VIEW_BIN, "--lcm-url", ptz::test::kTestUrl,
                                   "--screenshot-dir", out->shots};
  view.insert(view.end(), view_args.begin(), view_args.end());
  out->view = std::make_unique<ChildProcess>(view);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-detect"]["up"] && l.counters["ptz-view"]["up"]; }, 30s));
}

// Where the window shows `canvas` on the X screen (the exact match of it), or fails.
void findOnScreen(const cv::Mat& canvas, const std::string& root_png, cv::Point* at) {
  ASSERT_EQ(shell("import -window root " + root_png), 0);
  const cv::Mat screen = cv::imread(root_png);
  ASSERT_FALSE(screen.empty()) << root_png;
  cv::Mat score;
  cv::matchTemplate(screen, canvas, score, cv::TM_SQDIFF);
  double best = 0;
  cv::minMaxLoc(score, &best, nullptr, at);
  ASSERT_LT(best / static_cast<double>(canvas.total()), 1.0)
      << "the screen does not show the saved picture";
}

// A frame of two tracks: #3 (red_ball, confirmed, the target) and #5 (green_box, coasting),
// both cameras panned a little, on plain grey images where only the overlay has colour.
constexpr int64_t kSeq = 7;
const ptz::PtzPose kLeftPtz{0.05, 0.02, 1.0}, kRightPtz{0.02, 0.02, 1.0};
const double kTargetM[3] = {0.2, 0.0, 3.0}, kOtherM[3] = {-0.5, 0.25, 2.5};

ptzstereo::object_track_t track(int64_t id, const std::string& class_name, int8_t state,
                                const double p[3], double radius_m) {
  ptzstereo::object_track_t t{};
  t.id = id;
  t.class_name = class_name;
  t.state = state;
  std::memcpy(t.position_m, p, sizeof(t.position_m));
  t.radius_m = radius_m;
  t.object_index = -1;
  return t;
}

ptzstereo::object_tracks_t twoTracks() {
  ptzstereo::object_tracks_t m{};
  m.frame_seq = kSeq;
  m.left_ptz = {kLeftPtz.pan_rad, kLeftPtz.tilt_rad, kLeftPtz.zoom};
  m.right_ptz = {kRightPtz.pan_rad, kRightPtz.tilt_rad, kRightPtz.zoom};
  m.target_id = 3;
  m.target_reason = "locked on track 3 (red_ball) by class";
  m.tracks = {track(3, "red_ball", ptzstereo::object_track_t::STATE_CONFIRMED, kTargetM, 0.1),
              track(5, "green_box", ptzstereo::object_track_t::STATE_COASTING, kOtherM, 0.12)};
  m.num_tracks = 2;
  return m;
}

ptzstereo::control_state_t coasting() {
  ptzstereo::control_state_t s{};
  s.frame_seq = kSeq;
  s.state = ptzstereo::control_state_t::STATE_COASTING;
  s.target_id = 3;
  s.since_target_s = 0.4;
  s.search_waypoint = -1;
  s.reason = "following track 3's prediction";
  return s;
}

// Where a track is drawn in one camera: its projected centre and apparent radius, as the rig
// model says (independent of the viewer's drawing code).
struct Mark {
  cv::Point centre;
  int radius_px;
};
Mark markOf(ptz::Side side, const ptz::PtzPose& pose, const double p[3], double radius_m) {
  const ptz::CameraView v = ptz::StereoRig::makeDefault().view(side, pose);
  const Eigen::Vector3d position(p[0], p[1], p[2]);
  const Eigen::Vector2d px = v.project(position);
  const double range = (position - v.position_head_m).norm();
  return {cv::Point(static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y()))),
          static_cast<int>(std::lround(v.intrinsics.fx * radius_m / range))};
}

// The track's mark is in `image` of the canvas (0 left, 640 right): an x exactly at the projected
// centre and the circle crossing the column through it at centre.y - radius (2-3 px wide, AA).
void expectTrackAt(const cv::Mat& canvas, int x_offset, const Mark& m, const cv::Scalar& colour,
                   const std::string& what) {
  ASSERT_TRUE(m.centre.inside(cv::Rect(0, 0, 640, 480))) << what << " projects outside";
  const cv::Vec3b centre = canvas.at<cv::Vec3b>(m.centre.y, x_offset + m.centre.x);
  EXPECT_EQ(centre, cv::Vec3b(static_cast<uint8_t>(colour[0]), static_cast<uint8_t>(colour[1]),
                              static_cast<uint8_t>(colour[2])))
      << what << " centre at " << m.centre;
  int hits = 0;
  for (int dy = -2; dy <= 2; ++dy) {
    hits +=
        near(canvas.at<cv::Vec3b>(m.centre.y - m.radius_px + dy, x_offset + m.centre.x), colour);
  }
  EXPECT_GE(hits, 1) << what << " outline (radius " << m.radius_px << " px)";
  // And nowhere else that colour: a point beside the circle is the grey background.
  const int bx = std::clamp(m.centre.x + m.radius_px + 40, 0, 639);
  EXPECT_FALSE(near(canvas.at<cv::Vec3b>(m.centre.y - m.radius_px - 10, x_offset + bx), colour))
      << what;
}

void expectBothTracks(const cv::Mat& canvas) {
  using ptz::Side;
  expectTrackAt(canvas, 0, markOf(Side::kLeft, kLeftPtz, kTargetM, 0.1), ptz::tools::kTargetColour,
                "left: target #3");
  expectTrackAt(canvas, 640, markOf(Side::kRight, kRightPtz, kTargetM, 0.1),
                ptz::tools::kTargetColour, "right: target #3");
  expectTrackAt(canvas, 0, markOf(Side::kLeft, kLeftPtz, kOtherM, 0.12),
                ptz::tools::kCoastingColour, "left: coasting #5");
  expectTrackAt(canvas, 640, markOf(Side::kRight, kRightPtz, kOtherM, 0.12),
                ptz::tools::kCoastingColour, "right: coasting #5");
}

const cv::Scalar kGrey(90, 90, 90);

}  // namespace

// The click mapping, byte for byte: the camera clicked, the pixel of that camera's own image
// (the right image starts at x = 640 of the canvas; the view shows the canvas at 1:1).
TEST(ViewClick, EachImageIsItsCameraAtItsOwnPixels) {
  using ptzstereo::target_select_t;
  struct Case {
    int x, y;
    int8_t camera;
    double x_px, y_px;
  };
  for (const Case& c : {Case{0, 0, target_select_t::CAMERA_LEFT, 0, 0},
                        Case{123, 45, target_select_t::CAMERA_LEFT, 123, 45},
                        Case{639, 479, target_select_t::CAMERA_LEFT, 639, 479},
                        Case{640, 0, target_select_t::CAMERA_RIGHT, 0, 0},
                        Case{640 + 321, 200, target_select_t::CAMERA_RIGHT, 321, 200},
                        Case{1279, 479, target_select_t::CAMERA_RIGHT, 639, 479}}) {
    const auto m = ptz::tools::clickToSelect(c.x, c.y, 640, 480, 42, 1'700'000'000'123'456);
    ASSERT_TRUE(m) << c.x << "," << c.y;
    target_select_t want{};
    want.utime = 1'700'000'000'123'456;
    want.publish_utime = 1'700'000'000'123'456;
    want.mode = target_select_t::MODE_IMAGE_POINT;
    want.class_name = "";
    want.track_id = -1;
    want.camera = c.camera;
    want.x_px = c.x_px;
    want.y_px = c.y_px;
    want.frame_seq = 42;
    EXPECT_EQ(encoded(*m), encoded(want)) << "click at " << c.x << "," << c.y;
  }
  // The encoding itself, for one: x_px = 321.0 is 0x4074100000000000, big-endian, after the
  // hash, utime, publish_utime, mode, class_name (length 1, "\0"), track_id and camera.
  const auto m = ptz::tools::clickToSelect(640 + 321, 200, 640, 480, 42, 1);
  const std::vector<uint8_t> bytes = encoded(*m);
  const size_t x_at = 8 + 8 + 8 + 1 + 4 + 1 + 8 + 1;
  ASSERT_GE(bytes.size(), x_at + 8);
  EXPECT_EQ(std::vector<uint8_t>(bytes.begin() + x_at, bytes.begin() + x_at + 8),
            (std::vector<uint8_t>{0x40, 0x74, 0x10, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bytes[x_at - 1], 1);  // camera: right
}

TEST(ViewClick, OutsideBothImagesAsksNothing) {
  for (const auto& [x, y] : std::vector<std::pair<int, int>>{
           {-1, 10}, {10, -1}, {1280, 10}, {10, 480}, {700, 480 + 20}}) {
    EXPECT_FALSE(ptz::tools::clickToSelect(x, y, 640, 480, 1, 1)) << x << "," << y;
  }
  EXPECT_FALSE(ptz::tools::clickToSelect(0, 0, 0, 0, 1, 1)) << "no frame shown";
}

TEST(ViewState, TheControllersStateInWords) {
  ptzstereo::control_state_t s = coasting();
  EXPECT_EQ(ptz::tools::controlStateText(s), "COASTING 0.4 s");
  s.state = ptzstereo::control_state_t::STATE_SEARCHING;
  s.search_waypoint = 2;
  s.search_waypoints = 8;
  EXPECT_EQ(ptz::tools::controlStateText(s), "SEARCHING 3/8");
  s.state = ptzstereo::control_state_t::STATE_TRACKING;
  EXPECT_EQ(ptz::tools::controlStateText(s), "TRACKING");
  s.state = ptzstereo::control_state_t::STATE_HOLDING;
  s.since_target_s = 1.26;
  EXPECT_EQ(ptz::tools::controlStateText(s), "HOLDING 1.3 s");
  s.state = ptzstereo::control_state_t::STATE_HOMING;
  EXPECT_EQ(ptz::tools::controlStateText(s), "HOMING");
  s.state = 9;
  EXPECT_EQ(ptz::tools::controlStateText(s), "STATE 9?");
}

// drawView alone: each track where the rig projects it. Tracks that cannot be drawn (NaN,
// behind the cameras, an unknown state, an absurd radius, a huge class name or reason) cost
// nothing and break nothing.
TEST(ViewDraw, TracksWhereTheyProject) {
  ptz::tools::ViewInput in;
  in.left = cv::Mat(480, 640, CV_8UC3, kGrey);
  in.right = in.left.clone();
  in.left_ptz = kLeftPtz;
  in.right_ptz = kRightPtz;
  in.seq = kSeq;
  in.tracks = twoTracks();
  in.control = coasting();
  expectBothTracks(ptz::tools::drawView(ptz::StereoRig::makeDefault(), in));

  const double nan_m[3] = {NAN, 0, 3}, behind_m[3] = {0, 0, -3}, left_m[3] = {-3, 0, 1};
  in.tracks->tracks.push_back(track(8, "red_ball", 1, nan_m, 0.1));
  in.tracks->tracks.push_back(track(9, "red_ball", 1, behind_m, 0.1));
  in.tracks->tracks.push_back(track(10, std::string(100000, 'x'), 7, left_m, 1e300));
  in.tracks->num_tracks = static_cast<int32_t>(in.tracks->tracks.size());
  in.tracks->target_reason = std::string(100000, 'r');
  in.control->reason = std::string(100000, 'c');
  const auto t0 = std::chrono::steady_clock::now();
  const cv::Mat canvas = ptz::tools::drawView(ptz::StereoRig::makeDefault(), in);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
  ASSERT_EQ(canvas.size(), cv::Size(1280, 480 + ptz::tools::kPanelHeightPx));
}

TEST(View, TheScreenShowsBothImagesWithTheOverlay) {
  std::unique_ptr<ChildProcess> xvfb;
  startX(&xvfb);
  if (HasFatalFailure()) return;

  lcm::LCM lcm(ptz::test::kTestUrl);
  Listener l;
  l.listen(lcm);
  // A frame waits for its detections (however slow ptz-detect is here) before it is drawn.
  DetectAndView p;
  startDetectAndView(lcm, l, "view_shots", {"--max-wait-s", "5"}, &p);
  if (HasFatalFailure()) return;
  const std::string& shots = p.shots;
  ChildProcess& view = *p.view;
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
  const cv::Mat canvas = cv::imread(saved);
  ASSERT_FALSE(canvas.empty()) << saved;
  ASSERT_EQ(canvas.cols, 2 * 640);
  ASSERT_EQ(canvas.rows, 480 + ptz::tools::kPanelHeightPx);

  // Where the window put the picture: the exact match of the saved one.
  cv::Point at;
  findOnScreen(canvas, root, &at);
  ASSERT_FALSE(HasFatalFailure());
  const cv::Mat shown = cv::imread(root)(cv::Rect(at, canvas.size()));

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

// A monitoring host sees STEREO_PREVIEW, not the frames: scaled up to the rig's size, the ball is
// where ptz-detect found it in the full frames, under its outline.
TEST(View, APreviewIsDrawnAtTheRigsSizeUnderTheOverlay) {
  std::unique_ptr<ChildProcess> xvfb;
  startX(&xvfb);
  if (HasFatalFailure()) return;
  lcm::LCM lcm(ptz::test::kTestUrl);
  Listener l;
  l.listen(lcm);
  DetectAndView p;
  startDetectAndView(lcm, l, "view_preview_shots",
                     {"--preview", "true", "--screenshot-after-frames", "3", "--max-wait-s", "5"},
                     &p);
  if (HasFatalFailure()) return;
  const std::string& shots = p.shots;
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                    PTZ_SOURCE_DIR "/config/sim_paper.yaml", "--clock", "realtime", "--encoding",
                    "jpeg", "--frames", "90", "--preview-rate-hz", "10", "--preview-width-px",
                    "160"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-view"]["screenshots"] >= 1; }, 30s))
      << "ptz-view drew " << l.counters["ptz-view"]["frames_drawn"] << " previews";
  ptz::test::handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0; }, 30s);
  EXPECT_EQ(l.counters["ptz-view"]["STEREO_PREVIEW.dropped_size_mismatch"], 0);
  cv::Mat canvas;
  int64_t seq = -1;
  for (int64_t n = 0; n < 90 && canvas.empty(); ++n) {
    const std::string path = shots + "/ptz-view-" + std::to_string(n) + ".png";
    if (exists(path)) canvas = cv::imread(path);
    seq = n;
  }
  ASSERT_FALSE(canvas.empty()) << "no screenshot in " << shots;
  // Previews at 10 Hz of 30 Hz frames: at most a third drawn (frames skipped late on a busy
  // machine move the schedule off every third seq, so the count, not the seq, is checked).
  EXPECT_LE(l.counters["ptz-view"]["frames_drawn"], 31);
  ASSERT_EQ(canvas.cols, 2 * 640);
  EXPECT_TRUE(near(canvas.at<cv::Vec3b>(240 - 10, 320), ptz::tools::kCentreColour));
  ASSERT_TRUE(l.detections.count(seq) && l.poses.count(seq)) << "frame " << seq;
  const auto& pose = l.poses[seq];
  ASSERT_GE(pose.target_index, 0);
  const auto& obj = pose.objects[static_cast<size_t>(pose.target_index)];
  for (int side = 0; side < 2; ++side) {
    const auto& det = side == 0 ? l.detections[seq].left[static_cast<size_t>(obj.left_index)]
                                : l.detections[seq].right[static_cast<size_t>(obj.right_index)];
    // Half a radius below the centre: inside the ball, off the epipolar line through it.
    const double r_px = std::sqrt(det.area_px2 / M_PI);
    const cv::Vec3b p =
        canvas.at<cv::Vec3b>(static_cast<int>(std::lround(det.centroid_y_px + r_px / 2)),
                             side * 640 + static_cast<int>(det.centroid_x_px));
    // Red, however the ball is shaded there.
    EXPECT_TRUE(p[2] > 60 && p[2] > 2 * p[1] && p[2] > 2 * p[0])
        << "side " << side << ": not the red ball at its detection: " << p;
  }
  p.view->stop();
}

// Our own frame with two tracks and the controller coasting: the tracks drawn where they project
// (on the screen as in the saved picture), and a left click on #5 in the right image asks for
// that pixel of the right camera, of this frame, on TARGET_SELECT.
TEST(View, ShowsTracksAndAClickAsksForTheObjectUnderIt) {
  std::unique_ptr<ChildProcess> xvfb;
  startX(&xvfb);
  if (HasFatalFailure()) return;
  lcm::LCM lcm(ptz::test::kTestUrl);
  Listener l;
  lcm.subscribe("TARGET_SELECT", &Listener::onSelect, &l);
  lcm.subscribe("PROCESS_STATUS_.*", &Listener::onStatus, &l);
  const std::string shots = std::string(::testing::TempDir()) + "/view_track_shots";
  ::mkdir(shots.c_str(), 0755);
  ChildProcess view({PTZ_VIEW_BIN, "--lcm-url", ptz::test::kTestUrl, "--screenshot-dir", shots,
                     "--max-wait-s", "5"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-view"]["up"] != 0; }, 30s));

  // The frame's messages, then the frame (the view waits for them up to max_wait_s anyway).
  const int64_t now = ptz::wallUtime();
  ptzstereo::object_tracks_t tracks = twoTracks();
  tracks.utime = tracks.publish_utime = now;
  ptzstereo::object_detections_t detections{};
  detections.utime = detections.publish_utime = now;
  detections.frame_seq = kSeq;
  ptzstereo::object_pose_t pose{};
  pose.utime = pose.publish_utime = now;
  pose.frame_seq = kSeq;
  pose.target_index = -1;
  ptzstereo::control_state_t control = coasting();
  control.utime = control.publish_utime = now;
  const cv::Mat grey(480, 640, CV_8UC3, kGrey);
  ptzstereo::stereo_frame_t frame{};
  frame.utime = frame.publish_utime = now;
  frame.seq = kSeq;
  frame.left = ptz::encodeImage(grey, kLeftPtz, ptzstereo::image_t::ENCODING_RAW, 90);
  frame.right = ptz::encodeImage(grey, kRightPtz, ptzstereo::image_t::ENCODING_RAW, 90);
  lcm.publish("OBJECT_TRACKS", &tracks);
  lcm.publish("OBJECT_DETECTIONS", &detections);
  lcm.publish("OBJECT_POSE", &pose);
  lcm.publish("CONTROL_STATE", &control);
  lcm.publish("STEREO_FRAME", &frame);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-view"]["last_frame_drawn"] == kSeq; }, 15s))
      << "ptz-view drew " << l.counters["ptz-view"]["frames_drawn"] << " frames";

  ASSERT_EQ(shell("xdotool search --name ptz-view key s"), 0);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-view"]["screenshots"] >= 1; }, 10s))
      << "the s key saved nothing";
  const cv::Mat canvas = cv::imread(shots + "/ptz-view-" + std::to_string(kSeq) + ".png");
  ASSERT_FALSE(canvas.empty());
  ASSERT_EQ(canvas.size(), cv::Size(1280, 480 + ptz::tools::kPanelHeightPx));
  expectBothTracks(canvas);
  // The panel's two state lines have text in them (the words: TheControllersStateInWords).
  for (int row : {4, 5}) {
    const cv::Mat line = canvas(cv::Rect(0, 480 + 22 + row * 24 - 12, 640, 14));
    EXPECT_GT(cv::countNonZero(cv::Mat(line.reshape(1) > 200)), 50) << "row " << row;
  }
  cv::Point at;
  findOnScreen(canvas, shots + "/root.png", &at);
  ASSERT_FALSE(HasFatalFailure());

  // Click the coasting #5 in the right image.
  const Mark m = markOf(ptz::Side::kRight, kRightPtz, kOtherM, 0.12);
  const int64_t before = ptz::wallUtime();
  ASSERT_EQ(shell("xdotool mousemove " + std::to_string(at.x + 640 + m.centre.x) + " " +
                  std::to_string(at.y + m.centre.y) + " click 1"),
            0);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return !l.selects.empty(); }, 10s))
      << "the click published no TARGET_SELECT";
  const int64_t after = ptz::wallUtime();
  ASSERT_EQ(l.selects.size(), 1u);
  const ptzstereo::target_select_t& got = l.selects.front();
  EXPECT_GE(got.utime, before);
  EXPECT_LE(got.utime, after);
  ptzstereo::target_select_t want{};
  want.utime = got.utime;
  want.publish_utime = got.utime;
  want.mode = ptzstereo::target_select_t::MODE_IMAGE_POINT;
  want.track_id = -1;
  want.camera = ptzstereo::target_select_t::CAMERA_RIGHT;
  want.x_px = m.centre.x;
  want.y_px = m.centre.y;
  want.frame_seq = kSeq;
  EXPECT_EQ(encoded(got), encoded(want))
      << "camera " << int{got.camera} << " (" << got.x_px << ", " << got.y_px << ") of frame "
      << got.frame_seq << "; want the right image's (" << m.centre.x << ", " << m.centre.y << ")";
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-view"]["target_selects"] >= 1; }, 5s));

  ASSERT_EQ(shell("xdotool search --name ptz-view key q"), 0);
  EXPECT_EQ(view.wait(10s), 0);
}
