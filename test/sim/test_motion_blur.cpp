// The cameras' shutter (issue #32): motion blur against known answers. A ball crossing the view
// smears by its image speed times the exposure, a panning head smears a vertical edge by the pan
// rate times the exposure times fx; a still scene with an exposure is byte-identical to one
// without; bad values named.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "common/config.hpp"
#include "common/plant.hpp"
#include "sim/simulator.hpp"
#include "support/sim/scene_text.hpp"

using ptz::Side;
using ptz::StereoRig;
using ptz::sim::Scene;
using ptz::sim::Simulator;

namespace {

// The columns of row v whose pixel passes `is`: first and last (-1, -1 when none).
template <typename Is>
std::pair<int, int> extent(const cv::Mat& bgr, int v, Is is) {
  std::pair<int, int> e{-1, -1};
  for (int u = 0; u < bgr.cols; ++u) {
    if (!is(bgr.at<cv::Vec3b>(v, u))) continue;
    if (e.first < 0) e.first = u;
    e.second = u;
  }
  return e;
}

Scene ballScene() {
  return ptz::test::redBallScene(-0.2);
}

}  // namespace

TEST(MotionBlur, AStillSceneWithAnExposureIsByteIdentical) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene = ballScene();
  scene.posters.push_back({});  // a white poster too
  Simulator sharp(rig, scene, ptz::defaultPlantParams(), 2.0, 1);
  scene.camera.exposure_s = 0.05;
  scene.camera.blur_samples = 7;
  Simulator blurred(rig, scene, ptz::defaultPlantParams(), 2.0, 1);
  for (int k = 0; k < 4; ++k) {
    sharp.advanceTo(k / 30.0);
    blurred.advanceTo(k / 30.0);
    const ptz::sim::SimFrame a = sharp.capture(), b = blurred.capture();
    EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0) << "frame " << k;
    EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0) << "frame " << k;
    EXPECT_EQ(a.visible_fraction, b.visible_fraction);
  }
}

// A red ball at 3 m moving at 1 m/s along x (a line trajectory: x = t for |t| < 2 s),
// exposed 0.1 s: its red run along the row through its centre is longer by its image speed times
// the exposure (its projections at t - 0.05 s and t + 0.05 s apart), and centred on where it is at
// the frame's time.
TEST(MotionBlur, AMovingBallSmearsByItsImageSpeedTimesTheExposure) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene = ballScene();
  ptz::sim::Trajectory& path = scene.objects[0].trajectory;
  path.type = ptz::sim::Trajectory::Type::kLine;
  path.amplitude_m = {2, 0, 0};
  path.period_s = 8;
  const double t_s = 0.5, exposure_s = 0.1;
  Simulator sharp(rig, scene, ptz::defaultPlantParams(), 0.0, 1);
  scene.camera.exposure_s = exposure_s;
  Simulator blurred(rig, scene, ptz::defaultPlantParams(), 0.0, 1);
  sharp.advanceTo(t_s);
  blurred.advanceTo(t_s);
  const ptz::sim::SimFrame a = sharp.capture(), b = blurred.capture();
  const ptz::CameraView view = rig.view(Side::kLeft, a.left_pose);
  const Eigen::Vector2d now = view.project(path.position(t_s));
  const Eigen::Vector2d then = view.project(path.position(t_s - exposure_s / 2));
  const Eigen::Vector2d after = view.project(path.position(t_s + exposure_s / 2));
  const double smear_px = after.x() - then.x();
  // Red: the backdrop's red exceeds its green by at most 11; a fifth of the ball's by 23.
  const auto red = [](const cv::Vec3b& p) { return p[2] - p[1] > 15; };
  const int v = static_cast<int>(std::lround(now.y()));
  const auto sharp_run = extent(a.left, v, red), blurred_run = extent(b.left, v, red);
  const int sharp_px = sharp_run.second - sharp_run.first + 1;
  const int blurred_px = blurred_run.second - blurred_run.first + 1;
  std::cout << "ball: image speed " << smear_px / exposure_s << " px/s; red run " << sharp_px
            << " px sharp, " << blurred_px << " px blurred: longer by " << blurred_px - sharp_px
            << " px for speed x exposure = " << smear_px << " px\n";
  ASSERT_GT(smear_px, 10);
  EXPECT_NEAR(blurred_px - sharp_px, smear_px, 1.5);
  // The smear's middle is the ball at the frame's time.
  EXPECT_NEAR(blurred_run.first + blurred_run.second, sharp_run.first + sharp_run.second, 2);
  EXPECT_LT(std::abs(now.x() - (blurred_run.first + blurred_run.second) / 2.0), 1.0);
  EXPECT_NEAR(b.visible_fraction[0][0], 1.0, 1e-12);
}

// The left head panning at its rate limit (0.5 rad/s) across a vertical edge (black poster left,
// a saturated white one right): exposed a whole frame (1/30 s), the edge becomes a ramp
// rate x exposure x fx wide; without the exposure it is sharp.
TEST(MotionBlur, APanningHeadSmearsAnEdgeByRateTimesExposureTimesFx) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene;
  ptz::sim::Poster dark, bright;
  dark.centre_m = {-9, 0};
  dark.size_m = {20, 20};
  dark.color_bgr = {0, 0, 0};
  bright.centre_m = {11, 0};  // the edge at x = 1 m
  bright.size_m = {20, 20};
  bright.brightness = 3;
  scene.posters = {dark, bright};
  ptz::PtzPlant::Params plant = ptz::defaultPlantParams();
  plant.axis[ptz::PtzPlant::kPan].time_constant_s = 0.01;  // at the rate limit within a moment
  plant.axis[ptz::PtzPlant::kPan].max_rate_per_s = 0.5;
  const double exposure_s = 1 / 30.0;
  Simulator sharp(rig, scene, plant, 0.0, 1);
  scene.camera.exposure_s = exposure_s;
  Simulator blurred(rig, scene, plant, 0.0, 1);
  int clamped = 0, rejected = 0;
  for (Simulator* sim : {&sharp, &blurred}) {
    sim->command(0, {1.0, 0, 1}, {1.0, 0, 1}, &clamped, &rejected);
    sim->advanceTo(0.3);
    sim->capture();  // the frame before
    sim->advanceTo(0.3 + exposure_s);
  }
  const ptz::sim::SimFrame a = sharp.capture(), b = blurred.capture();
  const double rate = (b.left_pose.pan_rad - b.earlier_left_pose.pan_rad) / exposure_s;
  const ptz::CameraView view = rig.view(Side::kLeft, b.left_pose);
  const double expected_px = rate * exposure_s * view.intrinsics.fx;
  const Eigen::Vector2d edge = view.project({1, 0, scene.backdrop_distance_m});
  const int v = static_cast<int>(view.intrinsics.cy);
  const auto ramp = [](const cv::Vec3b& p) { return p[1] > 0 && p[1] < 255; };
  const auto sharp_ramp = extent(a.left, v, ramp), blurred_ramp = extent(b.left, v, ramp);
  const int ramp_px = blurred_ramp.second - blurred_ramp.first + 1;
  std::cout << "pan: rate " << rate << " rad/s, fx " << view.intrinsics.fx << ": expected "
            << expected_px << " px, ramp " << ramp_px << " px (from u = " << blurred_ramp.first
            << " to " << blurred_ramp.second << ", the edge now at " << edge.x() << ")\n";
  EXPECT_NEAR(rate, 0.5, 1e-3);
  ASSERT_GT(edge.x(), 50);
  ASSERT_LT(edge.x(), view.width - 50);
  EXPECT_EQ(sharp_ramp.first, -1);  // no grey between black and white without the exposure
  EXPECT_NEAR(ramp_px, expected_px, 1.5);
}

TEST(MotionBlur, BadValuesAreNamed) {
  const auto message = [](const std::string& camera) {
    const std::string path = std::string(::testing::TempDir()) + "/shutter.yaml";
    std::ofstream(path) << "%YAML:1.0\n---\nscene:\n  camera: " << camera << "\n";
    try {
      cv::FileStorage fs = ptz::openForRead(path, "config file");
      const Scene scene = Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"],
                                            "config file '" + path + "'");
      return "accepted " + std::to_string(scene.camera.exposure_s) + " " +
             std::to_string(scene.camera.blur_samples);
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
  };
  EXPECT_EQ(message("{ exposure_s: 0.02 }"), "accepted 0.020000 5");
  EXPECT_EQ(message("{ exposure_s: 0.2, blur_samples: 16 }"), "accepted 0.200000 16");
  EXPECT_NE(message("{ exposure_s: 0.3 }").find("scene.camera.exposure_s"), std::string::npos);
  EXPECT_NE(message("{ exposure_s: 0.01, blur_samples: 1 }").find("scene.camera.blur_samples"),
            std::string::npos);
  EXPECT_NE(message("{ blur_samples: 17 }").find("blur_samples"), std::string::npos);
  EXPECT_NE(message("{ shutter_s: 0.01 }").find("scene.camera.shutter_s: unknown field"),
            std::string::npos);
}
