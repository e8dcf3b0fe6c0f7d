// pcl_viewer (PCL 1.13) under Xvfb on a PCD written by writePcd: with the camera file written
// beside it, a cloud in the head frame (y down) opens upright and not mirrored, read from the
// screen's pixels (import). Without it, the same cloud opens upside down: why the file exists.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>

#include "perception/depth/cloud.hpp"
#include "support/child_process.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// An X server of our own on a display nobody holds (the lock files live in the shared /tmp).
std::string startX(std::unique_ptr<ChildProcess>* xvfb) {
  std::mt19937 rng(std::random_device{}());
  int display = 0;
  do {
    display = 100 + static_cast<int>(rng() % 800);
  } while (std::filesystem::exists("/tmp/.X" + std::to_string(display) + "-lock"));
  const std::string d = ":" + std::to_string(display);
  *xvfb = std::make_unique<ChildProcess>(std::vector<std::string>{
      "/usr/bin/Xvfb", d, "-screen", "0", "1100x800x24", "-nolisten", "tcp"});
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (shell("DISPLAY=" + d + " xdotool getdisplaygeometry > /dev/null 2>&1") != 0) {
    if (std::chrono::steady_clock::now() > deadline || (*xvfb)->wait(50ms) >= 0) return "";
  }
  return d;
}

// The head-frame scene: a red arrow pointing up (towards -y), its tip at y = -0.3 m, and a green
// square up and to the right (x > 0, y < 0), 2 m ahead.
ptzstereo::point_cloud_t arrowScene() {
  std::vector<cv::Point3f> points;
  std::vector<cv::Vec3b> colours;
  const cv::Vec3b red(0, 0, 255), green(0, 255, 0);  // BGR
  for (int i = 0; i <= 60; ++i) {
    points.emplace_back(0.0f, 0.3f - 0.01f * i, 2.0f);
    colours.push_back(red);
  }
  for (int i = 1; i <= 20; ++i) {
    for (const float side : {-1.0f, 1.0f}) {
      points.emplace_back(side * 0.01f * i, -0.3f + 0.01f * i, 2.0f);
      colours.push_back(red);
    }
  }
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 8; ++j) {
      points.emplace_back(0.3f + 0.01f * i, -0.2f + 0.01f * j, 2.0f);
      colours.push_back(green);
    }
  }
  ptz::perception::CloudParams params;
  params.voxel_size_m = 0;  // every point
  return ptz::perception::makeCloud(points, colours, params);
}

struct Blobs {
  cv::Point2d red, green;   // centroids on the screen (px, y down)
  double red_top_width_px;  // widest red row in the top and bottom thirds of the red
  double red_bottom_width_px;
  int red_px = 0, green_px = 0;
};

Blobs findBlobs(const cv::Mat& bgr) {
  Blobs b;
  cv::Mat red_mask, green_mask;
  cv::inRange(bgr, cv::Scalar(0, 0, 150), cv::Scalar(80, 80, 255), red_mask);
  cv::inRange(bgr, cv::Scalar(0, 150, 0), cv::Scalar(80, 255, 80), green_mask);
  b.red_px = cv::countNonZero(red_mask);
  b.green_px = cv::countNonZero(green_mask);
  if (b.red_px == 0 || b.green_px == 0) return b;
  const cv::Moments r = cv::moments(red_mask, true), g = cv::moments(green_mask, true);
  b.red = {r.m10 / r.m00, r.m01 / r.m00};
  b.green = {g.m10 / g.m00, g.m01 / g.m00};
  const cv::Rect box = cv::boundingRect(red_mask);
  b.red_top_width_px = b.red_bottom_width_px = 0;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const cv::Rect row = cv::boundingRect(red_mask.row(y));
    if (y < box.y + box.height / 3)
      b.red_top_width_px = std::max<double>(b.red_top_width_px, row.width);
    if (y >= box.y + 2 * box.height / 3) {
      b.red_bottom_width_px = std::max<double>(b.red_bottom_width_px, row.width);
    }
  }
  return b;
}

// pcl_viewer on `pcd` (and `extra` flags) until its points are on the screen; the screen then.
Blobs viewerShows(const std::string& pcd, const std::vector<std::string>& extra,
                  const std::string& png) {
  std::vector<std::string> argv = {"/usr/bin/pcl_viewer", pcd, "-ps", "5"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  ChildProcess viewer(argv, png + ".stderr.txt");
  EXPECT_TRUE(viewer.started());
  // Until both blobs are drawn and two screenshots in a row agree (the first frames may still
  // be the empty window).
  Blobs last;
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < deadline && viewer.running()) {
    if (shell("import -window root '" + png + "' 2> /dev/null") != 0) continue;
    const Blobs b = findBlobs(cv::imread(png));
    if (b.red_px > 100 && b.green_px > 100 && b.red_px == last.red_px &&
        b.green_px == last.green_px) {
      return b;
    }
    last = b;
  }
  ADD_FAILURE() << "pcl_viewer did not show the cloud: see " << png << ".stderr.txt";
  return last;
}

}  // namespace

TEST(PcdViewer, ACloudOpensUprightWithTheCameraFileWrittenBesideIt) {
  std::unique_ptr<ChildProcess> xvfb;
  const std::string display = startX(&xvfb);
  ASSERT_FALSE(display.empty()) << "Xvfb did not start";
  setenv("DISPLAY", display.c_str(), 1);
  const std::string dir = std::string(::testing::TempDir()) + "pcd_viewer/";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string pcd = dir + "arrow.pcd";
  std::string error;
  ASSERT_TRUE(ptz::perception::writePcd(arrowScene(), pcd, &error)) << error;
  ASSERT_TRUE(std::filesystem::exists(dir + "arrow.cam"));

  const Blobs upright = viewerShows(pcd, {"-cam", dir + "arrow.cam"}, dir + "with_cam.png");
  // The square is up and to the right of the arrow, and the arrow's head is at its top.
  EXPECT_GT(upright.green.x, upright.red.x + 20) << "mirrored: see " << dir << "with_cam.png";
  EXPECT_LT(upright.green.y, upright.red.y - 20) << "upside down: see " << dir << "with_cam.png";
  EXPECT_GT(upright.red_top_width_px, 3 * upright.red_bottom_width_px);
  // Everything in view: the 1024x768 window, the points inside it.
  EXPECT_GT(upright.red.x, 100);
  EXPECT_LT(upright.green.x, 1024 - 10);

  // Plain pcl_viewer turns the same file upside down (it ignores the PCD's VIEWPOINT for this).
  const Blobs plain = viewerShows(pcd, {}, dir + "plain.png");
  EXPECT_GT(plain.green.y, plain.red.y + 5) << "see " << dir << "plain.png";
  EXPECT_GT(plain.red_bottom_width_px, 3 * plain.red_top_width_px);
}

TEST(PcdViewer, TheCameraLooksFromTheHeadAtTheCloudWithMinusYUp) {
  // Points straight ahead at 4 m, 1 m either side: the focal point is their centroid, the view
  // up is -y, and the vertical field of view holds them in a 4:3 window (+10 %).
  const std::string cam = ptz::perception::pclViewerCamera({{-1, 0, 4}, {1, 0, 4}});
  EXPECT_EQ(cam.rfind("0.01,", 0), 0u) << cam;
  EXPECT_NE(cam.find("/0,0,4/0,0,0/0,-1,0/"), std::string::npos) << cam;
  const double fovy = std::stod(cam.substr(cam.find("/0,-1,0/") + 8));
  EXPECT_NEAR(fovy, 2 * std::atan(1.1 * 0.25 / (4.0 / 3.0)), 1e-6) << cam;
  EXPECT_NE(cam.find("/1024,768/0,0\n"), std::string::npos) << cam;
  EXPECT_EQ(ptz::perception::pclViewerCameraPath("out/cloud_12.pcd"), "out/cloud_12.cam");
  EXPECT_EQ(ptz::perception::pclViewerCameraPath("scene"), "scene.cam");
}
