// The simulated light against its analytic values: brightness keyframes, mains flicker and
// vignetting on a flat grey image, the auto-exposure's lag; off by default, which leaves a rendered
// frame byte-identical; a bad `light` map named.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>

#include "common/config.hpp"
#include "common/rig.hpp"
#include "sim/simulator.hpp"
#include "support/sim/scene_text.hpp"

using ptz::sim::Light;

namespace {

Light fromText(const std::string& light_map) {
  return ptz::test::lightFromText(light_map);
}

}  // namespace

TEST(Light, BrightnessFollowsItsKeyframesAndTheFlickerTheMains) {
  const Light ramp = fromText("{ brightness_s: [1, 3, 5], brightness: [1.0, 0.3, 1.0] }");
  EXPECT_DOUBLE_EQ(ramp.gainAt(0), 1.0);  // held before the first
  EXPECT_DOUBLE_EQ(ramp.gainAt(2), 0.65);
  EXPECT_DOUBLE_EQ(ramp.gainAt(3), 0.3);
  EXPECT_DOUBLE_EQ(ramp.gainAt(4.5), 0.3 + 0.7 * 0.75);
  EXPECT_DOUBLE_EQ(ramp.gainAt(9), 1.0);  // and after the last
  // 50 Hz mains: 100 Hz flicker, full at the mains' peaks, down 20 % at the zero crossings.
  const Light flicker = fromText("{ mains_hz: 50, flicker_depth: 0.2 }");
  EXPECT_NEAR(flicker.gainAt(0.005), 1.0, 1e-12);  // a quarter of 20 ms
  EXPECT_NEAR(flicker.gainAt(0.010), 0.8, 1e-12);
  EXPECT_NEAR(flicker.gainAt(0.015), 1.0, 1e-12);
  EXPECT_NEAR(flicker.gainAt(0.0025), 0.9, 1e-12);  // sin^2 = 1/2 half-way
  // A grey frame at 2 s of the ramp: every pixel 200 x 0.65.
  cv::Mat grey(48, 64, CV_8UC3, cv::Scalar(200, 200, 200));
  ramp.apply(2, &grey);
  EXPECT_EQ(grey.at<cv::Vec3b>(20, 30), cv::Vec3b(130, 130, 130));
  EXPECT_EQ(cv::countNonZero(grey.reshape(1) != 130), 0);
}

TEST(Light, VignettingDarkensTheCornersAsTheSquareOfTheRadius) {
  const Light lens = fromText("{ vignetting: 0.3 }");
  cv::Mat grey(481, 641, CV_8UC3, cv::Scalar(200, 200, 200));  // odd: a pixel at the centre
  lens.apply(0, &grey);
  EXPECT_EQ(grey.at<cv::Vec3b>(240, 320)[0], 200);  // the centre: untouched
  EXPECT_EQ(grey.at<cv::Vec3b>(0, 0)[1], 140);      // a corner: 70 %
  EXPECT_EQ(grey.at<cv::Vec3b>(480, 640)[2], 140);
  const double r2 = 320.0 * 320.0 / (320.0 * 320.0 + 240.0 * 240.0);  // the middle of an edge
  EXPECT_EQ(grey.at<cv::Vec3b>(240, 0)[0], cv::saturate_cast<uchar>(200 * (1 - 0.3 * r2)));
}

TEST(Light, OffByDefaultAFrameIsByteIdentical) {
  ptz::sim::Scene scene;
  scene.objects.resize(1);
  scene.objects[0].trajectory.centre_m = Eigen::Vector3d(0.2, 0, 3);
  ASSERT_TRUE(scene.light.off());
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ptz::sim::Simulator plain(rig, scene, ptz::defaultPlantParams(), 2.0, 1);
  ptz::sim::Scene lit_scene = scene;
  lit_scene.light.brightness_s = {0};
  lit_scene.light.brightness = {1.0};  // on, at a gain of 1: the same pixels
  ptz::sim::Simulator lit(rig, lit_scene, ptz::defaultPlantParams(), 2.0, 1);
  const ptz::sim::SimFrame a = plain.capture(), b = lit.capture();
  EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0);
  // Dimmed to 30 %: the image's mean follows (the noise's mean is zero).
  ptz::sim::Scene dim_scene = scene;
  dim_scene.light.brightness_s = {0};
  dim_scene.light.brightness = {0.3};
  ptz::sim::Simulator dim(rig, dim_scene, ptz::defaultPlantParams(), 0.0, 1);
  ptz::sim::Simulator clean(rig, scene, ptz::defaultPlantParams(), 0.0, 1);
  const double ratio = cv::mean(dim.capture().left)[1] / cv::mean(clean.capture().left)[1];
  EXPECT_NEAR(ratio, 0.3, 0.005);
}

// Dimmed to half in a step at 1 s: the auto-exposure's image is dark at first and comes back to
// its target as 1 - exp(-t / tau) (its gain going from 1 to 2).
TEST(Light, AutoExposureBringsADimmedImageBackWithItsLag) {
  ptz::sim::Scene scene;
  scene.objects.resize(1);
  scene.objects[0].trajectory.centre_m = Eigen::Vector3d(0.2, 0, 3);
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  const auto grey = [](const cv::Mat& bgr) {
    const cv::Scalar m = cv::mean(bgr);
    return (m[0] + m[1] + m[2]) / 3;
  };
  ptz::sim::Simulator even(rig, scene, ptz::defaultPlantParams(), 0.0, 1);
  const double target = grey(even.capture().left);
  scene.light.brightness_s = {1.0, 1.001};
  scene.light.brightness = {1.0, 0.5};
  scene.light.auto_exposure_target = target;  // where the even light's image already is
  scene.light.auto_exposure_time_constant_s = 0.3;
  ptz::sim::Simulator sim(rig, scene, ptz::defaultPlantParams(), 0.0, 1);
  std::map<int, double> at;  // frame -> the left image's mean grey, a share of the target
  for (int k = 0; k <= 75; ++k) {
    sim.advanceTo(k / 30.0);
    at[k] = grey(sim.capture().left) / target;
  }
  EXPECT_NEAR(at[29], 1.0, 0.002);  // before the step: the gain held at 1
  EXPECT_NEAR(at[31], 0.5, 0.03);   // just after: dark, the gain not moved yet
  // tau after the step (frame 39: 0.3 s), the gain 2 - exp(-1) of the way, and 5 tau after.
  for (const int k : {39, 75}) {
    const double expected = 0.5 * (2 - std::exp(-(k / 30.0 - 1.001) / 0.3));
    EXPECT_NEAR(at[k], expected, 0.03) << "frame " << k;
  }
  EXPECT_NEAR(at[75], 1.0, 0.03);
}

TEST(Light, BadLightIsNamed) {
  const auto message = ptz::test::lightErrorOf;
  EXPECT_NE(message("{ brightness_s: [0, 1], brightness: [1] }").find("1 values for 2 times"),
            std::string::npos);
  EXPECT_NE(message("{ brightness_s: [2, 1], brightness: [1, 1] }").find("times must increase"),
            std::string::npos);
  EXPECT_NE(message("{ vignetting: 2 }").find("vignetting"), std::string::npos);
  EXPECT_NE(message("{ flicker: 1 }").find("flicker"), std::string::npos);
  EXPECT_NE(message("{ brightness_s: [0], brightness: [-1] }").find("brightness"),
            std::string::npos);
  EXPECT_NE(message("[1, 2]").find("light: must be a map"), std::string::npos);
  EXPECT_NE(message("{ auto_exposure_max_gain: 0.5 }").find("auto_exposure_max_gain"),
            std::string::npos);
}
