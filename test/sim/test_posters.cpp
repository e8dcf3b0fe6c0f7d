// Posters on the backdrop (issue #32): where the rig projects them, in front of the backdrop's
// texture and behind the objects and the floor, textured a little, saturating when bright; a
// photograph stretched over one; none (or one out of view) leaves a frame byte-identical, the
// kept background and any band count too; a bad poster named.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <fstream>

#include "common/config.hpp"
#include "sim/render/renderer.hpp"
#include "sim/simulator.hpp"
#include "support/sim/scene_text.hpp"

using ptz::Side;
using ptz::StereoRig;
using ptz::sim::Poster;
using ptz::sim::Renderer;
using ptz::sim::Scene;

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = std::string(::testing::TempDir()) + "/" + name;
  std::ofstream(path) << text;
  return path;
}

Scene sceneOf(const std::string& path) {
  cv::FileStorage fs = ptz::openForRead(path, "config file");
  return Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"],
                           "config file '" + path + "'", std::string(::testing::TempDir()));
}

Poster poster(double x, double y, double w, double h, cv::Vec3b bgr, double brightness = 1) {
  Poster p;
  p.centre_m = {x, y};
  p.size_m = {w, h};
  p.color_bgr = bgr;
  p.brightness = brightness;
  return p;
}

Scene ballScene() {
  return ptz::test::redBallScene(0.2);
}

}  // namespace

TEST(Posters, NoneOrOneOutOfViewLeaveAFrameByteIdentical) {
  const StereoRig rig = StereoRig::makeDefault();
  const Scene plain = ballScene();
  ASSERT_TRUE(plain.posters.empty());
  Scene hung = plain;
  hung.posters.push_back(poster(40, 0, 2, 2, {0, 0, 255}));  // 40 m aside: out of view
  ptz::sim::Simulator a(rig, plain, ptz::defaultPlantParams(), 2.0, 1);
  ptz::sim::Simulator b(rig, hung, ptz::defaultPlantParams(), 2.0, 1);
  for (int k = 0; k < 3; ++k) {  // the third from the kept background
    const ptz::sim::SimFrame fa = a.capture(), fb = b.capture();
    EXPECT_EQ(cv::norm(fa.left, fb.left, cv::NORM_INF), 0) << "frame " << k;
    EXPECT_EQ(cv::norm(fa.right, fb.right, cv::NORM_INF), 0) << "frame " << k;
  }
  // A head turned away from the backdrop (its corners behind the camera) does not see it.
  hung.posters.push_back(poster(0, 0, 4, 4, {0, 0, 255}));
  Renderer bare_renderer(plain), hung_renderer(hung);
  const ptz::CameraView away = rig.view(Side::kLeft, {2.5, 0.3, 1});
  cv::Mat bare_image, hung_image;
  bare_renderer.render(away, 0.0, &bare_image);
  hung_renderer.render(away, 0.0, &hung_image);
  EXPECT_EQ(cv::norm(bare_image, hung_image, cv::NORM_INF), 0);
}

// A red poster 2 m x 1 m at 8 m, a red ball in front of it: its corners where the rig projects
// them, its colour the poster's times 0.85 .. 1.15 of the texture, the ball drawn over it.
TEST(Posters, APosterIsWhereTheRigProjectsItBehindTheObjects) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene = ballScene();
  scene.objects[0].trajectory.centre_m = Eigen::Vector3d(0.1, 0, 4);
  scene.posters.push_back(poster(0.3, -0.2, 2.0, 1.0, {40, 60, 200}));
  Renderer renderer(scene);
  const ptz::CameraView view = rig.view(Side::kLeft, {});
  cv::Mat img;
  std::vector<double> visible;
  renderer.render(view, 0.0, &img, &visible);
  const double z = scene.backdrop_distance_m;
  const Eigen::Vector2d tl = view.project({-0.7, -0.7, z}), br = view.project({1.3, 0.3, z});
  // One pixel inside each edge is the poster's, one outside is not (the backdrop's is grey).
  const auto posterish = [&](double u, double v) {
    const cv::Vec3b p =
        img.at<cv::Vec3b>(static_cast<int>(std::lround(v)), static_cast<int>(std::lround(u)));
    return p[2] > 2.5 * p[1];
  };
  const double mid_u = (tl.x() + br.x()) / 2, mid_v = (tl.y() + br.y()) / 2;
  EXPECT_TRUE(posterish(tl.x() + 1.5, mid_v));
  EXPECT_FALSE(posterish(tl.x() - 1.5, mid_v));
  EXPECT_TRUE(posterish(br.x() - 1.5, mid_v));
  EXPECT_FALSE(posterish(br.x() + 1.5, mid_v));
  EXPECT_TRUE(posterish(mid_u + 60, tl.y() + 1.5));
  EXPECT_FALSE(posterish(mid_u + 60, tl.y() - 1.5));
  EXPECT_TRUE(posterish(mid_u + 60, br.y() - 1.5));
  EXPECT_FALSE(posterish(mid_u + 60, br.y() + 1.5));
  // Its inside (away from the ball): the colour times the texture's 0.85 .. 1.15 (its green's
  // 40 .. 215), so it varies as 200 x 0.3 / 175 of the bare backdrop's green there.
  const cv::Rect inside(static_cast<int>(tl.x()) + 4, static_cast<int>(tl.y()) + 4, 40, 40);
  cv::Scalar mean, stddev, bare_mean, bare_stddev;
  cv::meanStdDev(img(inside), mean, stddev);
  Scene bare_scene = scene;
  bare_scene.posters.clear();
  Renderer bare_renderer(bare_scene);
  cv::Mat bare;
  bare_renderer.render(view, 0.0, &bare);
  cv::meanStdDev(bare(inside), bare_mean, bare_stddev);
  const double expected_stddev = 200 * 0.3 / 175 * bare_stddev[1];
  std::cout << "poster inside: mean " << mean << " stddev " << stddev << "; the bare backdrop's "
            << "green there " << bare_mean[1] << " +- " << bare_stddev[1] << ": red expected "
            << 200 * (0.85 + 0.3 * (bare_mean[1] - 40) / 175) << " +- " << expected_stddev << "\n";
  EXPECT_NEAR(mean[2], 200 * (0.85 + 0.3 * (bare_mean[1] - 40) / 175), 0.5);
  EXPECT_NEAR(stddev[2], expected_stddev, 0.05 * expected_stddev + 0.1);
  EXPECT_NEAR(mean[0] / mean[2], 40.0 / 200, 0.01);
  double lo = 0, hi = 0;
  cv::minMaxLoc(img(inside).clone().reshape(1), &lo, &hi);
  EXPECT_GE(lo, std::floor(40 * 0.85));
  EXPECT_LE(hi, std::ceil(200 * 1.15));
  // The ball in front: its centre pure red, and all of it shown.
  const Eigen::Vector2d ball = view.project(scene.objects[0].trajectory.centre_m);
  const cv::Vec3b c = img.at<cv::Vec3b>(static_cast<int>(ball.y()), static_cast<int>(ball.x()));
  EXPECT_EQ(c[0], 0);
  EXPECT_EQ(c[1], 0);
  ASSERT_EQ(visible.size(), 1u);
  EXPECT_DOUBLE_EQ(visible[0], 1.0);
}

// Hung below the floor's horizon, a poster shows only above it: the floor is in front. A bright
// window (3 x a light grey) saturates.
TEST(Posters, TheFloorHidesAPosterAndABrightOneSaturates) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene;
  scene.floor_height_m = 0.5;  // the floor meets the backdrop at y = 0.5 m
  scene.posters.push_back(poster(0, 0.5, 3, 1.6, {200, 200, 200}, 3.0));
  Renderer renderer(scene);
  const ptz::CameraView view = rig.view(Side::kLeft, {});
  cv::Mat img;
  renderer.render(view, 0.0, &img);
  const double z = scene.backdrop_distance_m;
  const Eigen::Vector2d top = view.project({0, -0.3, z}), horizon = view.project({0, 0.5, z});
  const int u = static_cast<int>(horizon.x());
  const int start = static_cast<int>(top.y()) + 2;
  int white = 0, white_below = 0;
  for (int v = start; v < img.rows; ++v) {
    const bool w = img.at<cv::Vec3b>(v, u) == cv::Vec3b(255, 255, 255);
    white += w;
    white_below += w && v > horizon.y() + 1;
  }
  // The rows from the start down to the horizon's (a pixel's centre at its index).
  const int expected = static_cast<int>(std::floor(horizon.y())) - start + 1;
  std::cout << "saturated rows above the horizon " << white << " of " << expected << ", below it "
            << white_below << "\n";
  EXPECT_NEAR(white, expected, 1);
  EXPECT_EQ(white_below, 0);
}

// The background pass draws the posters: drawn directly, from the kept background, and in any
// band count the same bytes; the chessboard in front of a poster.
TEST(Posters, KeptBackgroundAndBandsGiveTheSameBytes) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene = ballScene();
  scene.posters.push_back(poster(-0.5, 0, 3, 2, {30, 200, 30}));
  scene.posters.push_back(poster(0.5, 0.3, 1, 1, {200, 30, 30}, 2));  // in front of the first
  scene.chessboard.present = true;
  scene.chessboard.centre_head_m = {0, 0, 4};
  const ptz::CameraView view = rig.view(Side::kLeft, {0.05, 0.02, 1.3});
  Renderer renderer(scene);
  cv::Mat first, second, third;
  renderer.render(view, 0.0, &first);
  renderer.render(view, 0.0, &second);  // kept from here
  renderer.render(view, 0.0, &third);   // copied from the kept background
  EXPECT_EQ(cv::norm(first, second, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(first, third, cv::NORM_INF), 0);
  for (const int bands : {1, 7}) {
    Renderer banded(scene);
    banded.setBands(bands);
    cv::Mat img;
    banded.render(view, 0.0, &img);
    EXPECT_EQ(cv::norm(first, img, cv::NORM_INF), 0) << bands << " bands";
  }
  // The second poster over the first, the chessboard over both (its centre square dark or light).
  const double z = scene.backdrop_distance_m;
  const Eigen::Vector2d p2 = view.project({0.7, 0.5, z});
  const cv::Vec3b c2 = first.at<cv::Vec3b>(static_cast<int>(p2.y()), static_cast<int>(p2.x()));
  EXPECT_GT(c2[0], 2 * c2[1]);
  const Eigen::Vector2d board = view.project(scene.chessboard.centre_head_m);
  const cv::Vec3b cb =
      first.at<cv::Vec3b>(static_cast<int>(board.y()), static_cast<int>(board.x()));
  EXPECT_LT(std::abs(cb[0] - cb[1]) + std::abs(cb[1] - cb[2]), 10) << cb;
}

// A photograph (four coloured quadrants, a relative path from the config's folder) stretched over
// a poster: each quadrant where the rig projects it, their border within a pixel.
TEST(Posters, APhotographIsStretchedOverThePoster) {
  cv::Mat photo(300, 400, CV_8UC3);
  photo(cv::Rect(0, 0, 200, 150)).setTo(cv::Scalar(255, 0, 0));
  photo(cv::Rect(200, 0, 200, 150)).setTo(cv::Scalar(0, 255, 0));
  photo(cv::Rect(0, 150, 200, 150)).setTo(cv::Scalar(0, 0, 255));
  photo(cv::Rect(200, 150, 200, 150)).setTo(cv::Scalar(255, 255, 255));
  ASSERT_TRUE(cv::imwrite(std::string(::testing::TempDir()) + "/quadrants.png", photo));
  const Scene scene = sceneOf(
      writeTemp("photo.yaml",
                "%YAML:1.0\n---\nscene:\n  posters:\n"
                "    - { centre_m: [0.5, 0.25], size_m: [4, 3], image: \"quadrants.png\" }\n"));
  ASSERT_EQ(scene.posters.size(), 1u);
  ASSERT_FALSE(scene.posters[0].image_levels.empty());
  Renderer renderer(scene);
  const ptz::CameraView view = StereoRig::makeDefault().view(Side::kLeft, {});
  cv::Mat img;
  renderer.render(view, 0.0, &img);
  const double z = scene.backdrop_distance_m;
  const auto at = [&](double x, double y) {
    const Eigen::Vector2d p = view.project({x, y, z});
    return img.at<cv::Vec3b>(static_cast<int>(p.y()), static_cast<int>(p.x()));
  };
  EXPECT_EQ(at(-0.5, -0.5), cv::Vec3b(255, 0, 0));
  EXPECT_EQ(at(1.5, -0.5), cv::Vec3b(0, 255, 0));
  EXPECT_EQ(at(-0.5, 1.0), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(at(1.5, 1.0), cv::Vec3b(255, 255, 255));
  // The quadrants' border where the rig projects the photograph's middle, within a pixel.
  const Eigen::Vector2d middle = view.project({0.5, 0.25, z});
  const int v = static_cast<int>(middle.y()) - 20;
  int first_green = -1;
  for (int u = static_cast<int>(view.project({-0.5, 0, z}).x()); u < img.cols; ++u) {
    const cv::Vec3b p = img.at<cv::Vec3b>(v, u);
    if (p[1] > 128 && p[0] < 128) {
      first_green = u;
      break;
    }
  }
  std::cout << "the photograph's middle at u = " << middle.x() << ", its green from " << first_green
            << "\n";
  EXPECT_NEAR(first_green, middle.x(), 1.0);
}

TEST(Posters, BadPostersAreNamedWithTheirFieldAndValue) {
  const auto message = [](const std::string& posters) {
    try {
      sceneOf(writeTemp("bad_poster.yaml", "%YAML:1.0\n---\nscene:\n  posters: " + posters + "\n"));
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const auto expectIn = [&](const std::string& posters, const std::string& part) {
    const std::string m = message(posters);
    EXPECT_NE(m.find(part), std::string::npos) << posters << " -> " << m;
    EXPECT_NE(m.find("bad_poster.yaml"), std::string::npos) << m;
  };
  expectIn("[ { centre_m: [0, 0], size_m: [0, 1], color_bgr: [0, 0, 0] } ]",
           "scene.posters[0].size_m");
  expectIn("[ { centre_m: [0, 0], size_m: [1, 1], color_bgr: [0, 0, 0], brightness: 11 } ]",
           "scene.posters[0].brightness");
  expectIn("[ { centre_m: [0, 0], size_m: [1, 1], color_bgr: [0, 0, 300] } ]",
           "scene.posters[0].color_bgr");
  expectIn("[ { centre_m: [0, 0], size_m: [1, 1], colour: [0, 0, 0] } ]",
           "scene.posters[0].colour: unknown field");
  expectIn("[ { centre_m: [0, 0], size_m: [1, 1] } ]", "color_bgr");
  expectIn("{ centre_m: [0, 0] }", "scene.posters: must be a list");
  expectIn("[ { centre_m: [0, 0], size_m: [1, 1], image: \"no_such.png\" } ]",
           "scene.posters[0].image = 'no_such.png': '");
  expectIn("[ { centre_m: [0, 0], size_m: [1, 1], image: \"no_such.png\" } ]", "does not exist");
  writeTemp("empty.png", "");
  expectIn("[ { centre_m: [0, 0], size_m: [1, 1], image: \"empty.png\" } ]",
           "empty.png' cannot be read as an image");
  expectIn("[ { centre_m: [0, 0], size_m: [1, 1], image: \"empty.png\", color_bgr: [1, 1, 1] } ]",
           "exclude each other");
  std::string many = "[";
  for (int i = 0; i < 17; ++i)
    many += "{ centre_m: [0, 0], size_m: [1, 1], color_bgr: [0, 0, 0] },";
  many.back() = ']';
  expectIn(many, "at most 16 posters, got 17");
}
