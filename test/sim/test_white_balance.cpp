// The light's colour and the cameras' auto white balance (issue #32) against their analytic
// values: the tint's gains on a flat grey image, the grey-world balance's lag on a tinted grey
// scene (1 - exp(-1) of the way after one time constant, equal channel means after five), its
// gains' bounds; off or neutral, a frame byte-identical; bad values named.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "common/config.hpp"
#include "common/rig.hpp"
#include "sim/simulator.hpp"
#include "support/sim/scene_text.hpp"

using ptz::sim::AutoWhiteBalance;
using ptz::sim::Light;

namespace {

Light fromText(const std::string& light_map) {
  return ptz::test::lightFromText(light_map);
}

// Grey everywhere: a grey poster over the whole view, the floor far below it.
ptz::sim::Scene greyScene() {
  ptz::sim::Scene scene;
  scene.floor_height_m = 100;
  ptz::sim::Poster grey;
  grey.size_m = {100, 100};
  grey.color_bgr = {128, 128, 128};
  scene.posters.push_back(grey);
  return scene;
}

}  // namespace

TEST(WhiteBalance, TheLightsTintGainsItsChannels) {
  cv::Mat grey(48, 64, CV_8UC3, cv::Scalar(100, 100, 100));
  const Light warm = fromText("{ tint_bgr: [0.8, 1.0, 1.2] }");
  EXPECT_FALSE(warm.off());
  warm.apply(0, &grey);
  EXPECT_EQ(cv::countNonZero(grey.reshape(1) == 0), 0);
  EXPECT_EQ(grey.at<cv::Vec3b>(20, 30), cv::Vec3b(80, 100, 120));
  EXPECT_EQ(cv::norm(grey, cv::Mat(48, 64, CV_8UC3, cv::Scalar(80, 100, 120)), cv::NORM_INF), 0);
  // With the brightness and the vignetting: their gains times the tint's.
  const Light dim = fromText(
      "{ tint_bgr: [0.8, 1.0, 1.2], brightness_s: [0], brightness: [0.5], "
      "vignetting: 0.3 }");
  cv::Mat big(481, 641, CV_8UC3, cv::Scalar(200, 200, 200));
  dim.apply(0, &big);
  EXPECT_EQ(big.at<cv::Vec3b>(240, 320), cv::Vec3b(80, 100, 120));  // the centre
  EXPECT_EQ(big.at<cv::Vec3b>(0, 0), cv::Vec3b(56, 70, 84));        // a corner: 70 %
}

TEST(WhiteBalance, OffByDefaultAndNeutralAFrameIsByteIdentical) {
  const Light neutral = fromText("{ tint_bgr: [1, 1, 1], auto_white_balance_time_constant_s: 0 }");
  EXPECT_TRUE(neutral.off());
  EXPECT_EQ(Light().tint_bgr, cv::Vec3d(1, 1, 1));
  EXPECT_EQ(Light().auto_white_balance_time_constant_s, 0);
  ptz::sim::Scene scene;
  scene.objects.resize(1);
  scene.objects[0].trajectory.centre_m = Eigen::Vector3d(0.2, 0, 3);
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ptz::sim::Simulator plain(rig, scene, ptz::defaultPlantParams(), 2.0, 1);
  scene.light = neutral;
  ptz::sim::Simulator same(rig, scene, ptz::defaultPlantParams(), 2.0, 1);
  for (int k = 0; k < 3; ++k) {
    plain.advanceTo(k / 30.0);
    same.advanceTo(k / 30.0);
    const ptz::sim::SimFrame a = plain.capture(), b = same.capture();
    EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0);
  }
}

// A grey scene under a warm lamp (blue 0.8, red 1.2): the white balance's blue and red gains go
// from 1 to 1.25 and 1 / 1.2 as 1 - exp(-t / tau). The image at frame k shows the gains after
// frame k - 1.
TEST(WhiteBalance, ATintedGreySceneComesToEqualChannelMeansWithItsLag) {
  ptz::sim::Scene scene = greyScene();
  scene.light.tint_bgr = {0.8, 1.0, 1.2};
  const double tau_s = 0.3;
  scene.light.auto_white_balance_time_constant_s = tau_s;
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ptz::sim::Simulator sim(rig, scene, ptz::defaultPlantParams(), 0.0, 1);
  std::vector<cv::Scalar> means;
  for (int k = 0; k <= 46; ++k) {
    sim.advanceTo(k / 30.0);
    means.push_back(cv::mean(sim.capture().left));
  }
  const auto blue = [&](int k) { return means[k][0] / means[k][1]; };
  const auto red = [&](int k) { return means[k][2] / means[k][1]; };
  EXPECT_NEAR(blue(0), 0.8, 0.005);
  EXPECT_NEAR(red(0), 1.2, 0.005);
  // One tau (frame 10 shows the gains at 0.3 s): 1 - exp(-1) of the way from the tint to grey.
  const double way_b = (blue(10) - 0.8) / 0.2, way_r = (1.2 - red(10)) / 0.2;
  // Five tau (frame 46: 1.5 s): equal means within 2 %.
  std::cout << "after one tau: blue " << way_b << ", red " << way_r
            << " of the way (1 - exp(-1) = " << 1 - std::exp(-1.0) << "); after five: blue / green "
            << blue(46) << ", red / green " << red(46) << "\n";
  EXPECT_NEAR(way_b, 1 - std::exp(-1.0), 0.02);
  EXPECT_NEAR(way_r, 1 - std::exp(-1.0), 0.02);
  EXPECT_NEAR(blue(46), 1.0, 0.02);
  EXPECT_NEAR(red(46), 1.0, 0.02);
}

// A view all red (a head panned onto a big red poster): the gains go to their bounds and stay.
TEST(WhiteBalance, GainsStayWithinTheirBounds) {
  Light light;
  light.auto_white_balance_time_constant_s = 0.1;
  AutoWhiteBalance awb;
  for (int k = 0; k <= 60; ++k) {
    cv::Mat red(48, 64, CV_8UC3, cv::Scalar(10, 50, 250));
    awb.apply(light, k / 30.0, &red);
    ASSERT_GE(awb.blueGain(), AutoWhiteBalance::kMinGain);
    ASSERT_LE(awb.blueGain(), AutoWhiteBalance::kMaxGain);
    ASSERT_GE(awb.redGain(), AutoWhiteBalance::kMinGain);
  }
  EXPECT_NEAR(awb.blueGain(), 4.0, 1e-6);  // wanted 5
  EXPECT_NEAR(awb.redGain(), 0.25, 1e-6);  // wanted 0.2
  // Off: nothing happens.
  AutoWhiteBalance off;
  cv::Mat red(48, 64, CV_8UC3, cv::Scalar(10, 50, 250));
  off.apply(Light(), 1.0, &red);
  EXPECT_EQ(red.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 50, 250));
  EXPECT_EQ(off.blueGain(), 1.0);
}

TEST(WhiteBalance, BadValuesAreNamed) {
  const auto message = ptz::test::lightErrorOf;
  EXPECT_NE(message("{ tint_bgr: [1, 1] }").find("tint_bgr"), std::string::npos);
  EXPECT_NE(message("{ tint_bgr: [1, 5, 1] }").find("tint_bgr"), std::string::npos);
  EXPECT_NE(message("{ auto_white_balance_time_constant_s: -1 }")
                .find("auto_white_balance_time_constant_s"),
            std::string::npos);
}
