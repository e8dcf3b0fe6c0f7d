// The light's direction over time and the shadows on the floor (issue #32) against known answers:
// absent, every image as before, byte for byte; a sphere under a light straight down shadows a
// disc of its radius below it, an oblique light moves the shadow to where the ray from its centre
// away from the light meets the floor; the lit side of a matte sphere turns with the light; an
// object in front hides a shadow; a shadow keeps exactly 1 - shadow_depth of the floor's light;
// bands and the kept background give the same bytes; bad values named.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <fstream>

#include "common/config.hpp"
#include "sim/render/renderer.hpp"
#include "sim/simulator.hpp"
#include "support/sim/scene_text.hpp"

using ptz::Side;
using ptz::StereoRig;
using ptz::sim::Light;
using ptz::sim::Renderer;
using ptz::sim::Scene;
using ptz::sim::SceneObject;

namespace {

constexpr double kFloor_m = 0.6;  // near enough below the cameras to see it at 2 .. 3 m

SceneObject sphere(const Eigen::Vector3d& centre_m, double radius_m, cv::Vec3b bgr) {
  SceneObject o;
  o.radius_m = radius_m;
  o.color_bgr = bgr;
  o.trajectory.centre_m = centre_m;
  return o;
}

// A red sphere of radius 0.25 m above the floor, at 2.5 m; no shadows yet.
Scene sphereScene(const Eigen::Vector3d& to_light) {
  Scene scene;
  scene.floor_height_m = kFloor_m;
  scene.objects.push_back(sphere({0.2, -0.2, 2.5}, 0.25, {0, 0, 255}));
  scene.light.direction_s = {0};
  scene.light.direction = {to_light.normalized()};
  return scene;
}

cv::Mat render(const Scene& scene, const ptz::CameraView& view, double t_s = 0) {
  Renderer renderer(scene);
  cv::Mat img;
  renderer.render(view, t_s, &img);
  return img;
}

// Pixels where a and b differ (CV_8U, 255).
cv::Mat differing(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  cv::Mat grey;
  cv::transform(diff, grey, cv::Matx13f(1, 1, 1));
  return grey > 0;
}

// The image of a scene with its shadows and without them: the shadowed pixels.
struct Shadowed {
  cv::Mat lit, unshadowed, mask;
};

Shadowed shadowsOf(Scene scene, const ptz::CameraView& view, double t_s = 0) {
  Shadowed s;
  scene.light.shadows = false;
  s.unshadowed = render(scene, view, t_s);
  scene.light.shadows = true;
  s.lit = render(scene, view, t_s);
  s.mask = differing(s.lit, s.unshadowed);
  return s;
}

cv::Point2d centroid(const cv::Mat& mask) {
  const cv::Moments m = cv::moments(mask, true);
  return {m.m10 / m.m00, m.m01 / m.m00};
}

// The mask's pixels' points on the floor y = floor_m, and their centroid weighted by each
// pixel's area on the floor (H^2 / d_y^3 per unit of normalised image area, H the floor's depth
// below the camera, d the ray (x, y, 1) turned into the head frame): the area centroid of the
// shadow on the floor, which the perspective does not bias as it does the pixels' centroid.
Eigen::Vector3d floorCentroid(const cv::Mat& mask, const ptz::CameraView& view,
                              const Scene& scene) {
  Renderer renderer(scene);
  const cv::Mat& rays = renderer.rays(view);
  const Eigen::Vector3d& c = view.position_head_m;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double weight = 0;
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      if (!mask.at<uchar>(v, u)) continue;
      const cv::Vec2f ray = rays.at<cv::Vec2f>(v, u);
      const Eigen::Vector3d d = view.rotation_head_camera * Eigen::Vector3d(ray[0], ray[1], 1);
      const double w = 1 / (d.y() * d.y() * d.y());
      sum += w * (c + (scene.floor_height_m - c.y()) / d.y() * d);
      weight += w;
    }
  }
  return sum / weight;
}

std::string lightError(const std::string& light_map) {
  try {
    ptz::test::lightFromText(light_map);
  } catch (const ptz::ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

}  // namespace

// Absent, the direction is the one the objects always had, exactly; one keyframe at it, shadows
// off (at any depth) or on with nothing to cast them give the same bytes. (Checked once against
// the code before the direction on config/sim_*.yaml and test/scenarios/*.yaml, 12 frames each
// with a pan and a zoom: byte-identical.)
TEST(LightDirection, AbsentOrAtTheOldDirectionEveryImageIsByteIdentical) {
  const Light none;
  EXPECT_EQ(none.toLightAt(3.0), Eigen::Vector3d(-0.3, -0.8, -0.5).normalized());
  EXPECT_FALSE(none.shadows);
  EXPECT_EQ(none.shadow_depth, 0.55);
  const Light read = ptz::test::lightFromText(
      "{ direction: [[-0.3, -0.8, -0.5]], shadows: false, shadow_depth: 0.9 }");
  EXPECT_EQ(read.toLightAt(0), none.toLightAt(0));

  const StereoRig rig = StereoRig::makeDefault();
  Scene plain = ptz::test::redBallScene(0.2);
  SceneObject box;
  box.shape = SceneObject::Shape::kBox;
  box.half_extents_m = {0.2, 0.15, 0.1};
  box.yaw_rad = 0.4;
  box.trajectory.centre_m = {-0.4, 0.1, 2.5};
  plain.objects.push_back(box);
  Scene same = plain;
  same.light = read;
  Scene empty_lit;  // shadows on, nothing to cast them
  empty_lit.light.shadows = true;
  ptz::sim::Simulator a(rig, plain, ptz::defaultPlantParams(), 2.0, 1);
  ptz::sim::Simulator b(rig, same, ptz::defaultPlantParams(), 2.0, 1);
  ptz::sim::Simulator c(rig, Scene(), ptz::defaultPlantParams(), 2.0, 1);
  ptz::sim::Simulator d(rig, empty_lit, ptz::defaultPlantParams(), 2.0, 1);
  for (int k = 0; k < 3; ++k) {  // the third from the kept background
    const ptz::sim::SimFrame fa = a.capture(), fb = b.capture(), fc = c.capture(), fd = d.capture();
    EXPECT_EQ(cv::norm(fa.left, fb.left, cv::NORM_INF), 0) << "frame " << k;
    EXPECT_EQ(cv::norm(fa.right, fb.right, cv::NORM_INF), 0) << "frame " << k;
    EXPECT_EQ(cv::norm(fc.left, fd.left, cv::NORM_INF), 0) << "frame " << k;
  }
}

TEST(LightDirection, KeyframesAreNormalisedInterpolatedAndHeld) {
  const Light light =
      ptz::test::lightFromText("{ direction_s: [1, 3], direction: [[0, -2, 0], [0, 0, -5]] }");
  ASSERT_EQ(light.direction.size(), 2u);
  EXPECT_NEAR((light.toLightAt(0) - Eigen::Vector3d(0, -1, 0)).norm(), 0, 1e-15);  // held
  EXPECT_NEAR((light.toLightAt(9) - Eigen::Vector3d(0, 0, -1)).norm(), 0, 1e-15);
  // Half-way: the bisector (normalised linear interpolation).
  EXPECT_NEAR((light.toLightAt(2) - Eigen::Vector3d(0, -1, -1).normalized()).norm(), 0, 1e-15);
  EXPECT_NEAR(light.toLightAt(1.5).norm(), 1.0, 1e-15);
  // One direction, no times: held for ever; a flat [x, y, z] is one direction.
  const Light fixed = ptz::test::lightFromText("{ direction: [0, -3, 4] }");
  EXPECT_NEAR((fixed.toLightAt(100) - Eigen::Vector3d(0, -0.6, 0.8)).norm(), 0, 1e-15);
}

// A sphere of radius r with the light straight down: its shadow is the disc of radius r on the
// floor below its centre; every shadowed pixel keeps 1 - shadow_depth of its light, the rest are
// untouched.
TEST(Shadows, ALightStraightDownShadowsADiscOfTheRadiusBelowTheCentre) {
  const ptz::CameraView view = StereoRig::makeDefault().view(Side::kLeft, {});
  const Scene scene = sphereScene({0, -1, 0});
  const Shadowed s = shadowsOf(scene, view);
  const Eigen::Vector3d c = scene.objects[0].trajectory.centre_m;
  const double r = scene.objects[0].radius_m;
  ASSERT_GT(cv::countNonZero(s.mask), 500);
  const cv::Point2d mean = centroid(s.mask);
  const Eigen::Vector2d below = view.project({c.x(), kFloor_m, c.z()});
  const Eigen::Vector2d area_centre = view.project(floorCentroid(s.mask, view, scene));
  const cv::Rect box = cv::boundingRect(s.mask);
  // The disc's extreme points: left and right at its centre's depth, near and far.
  const double left = view.project({c.x() - r, kFloor_m, c.z()}).x();
  const double right = view.project({c.x() + r, kFloor_m, c.z()}).x();
  const double far = view.project({c.x(), kFloor_m, c.z() + r}).y();
  const double near = view.project({c.x(), kFloor_m, c.z() - r}).y();
  std::cout << "shadow: " << cv::countNonZero(s.mask) << " px, its area centroid at ("
            << area_centre.x() << ", " << area_centre.y() << ") against the centre below ("
            << below.x() << ", " << below.y() << ") (its pixels' centroid at (" << mean.x << ", "
            << mean.y << "), nearer in perspective); columns " << box.x << " .. "
            << box.x + box.width - 1 << " against " << left << " .. " << right << ", rows " << box.y
            << " .. " << box.y + box.height - 1 << " against " << far << " .. " << near << "\n";
  EXPECT_NEAR(area_centre.x(), below.x(), 0.5);
  EXPECT_NEAR(area_centre.y(), below.y(), 0.5);
  EXPECT_NEAR(mean.x, below.x(), 1.0);
  EXPECT_NEAR(mean.y, below.y(), 1.5);  // the near half is larger in the image
  // A pixel is shadowed when its centre is: the extreme pixels within a pixel of the edge.
  EXPECT_NEAR(box.x, left, 1.0);
  EXPECT_NEAR(box.x + box.width - 1, right, 1.0);
  EXPECT_NEAR(box.y, far, 1.0);
  EXPECT_NEAR(box.y + box.height - 1, near, 1.0);
  // Exactly 1 - shadow_depth of the light, rounded (no noise): 0.45 by default, 0.7 at 0.3.
  for (const double depth : {0.55, 0.3}) {
    Scene deep = scene;
    deep.light.shadow_depth = depth;
    const Shadowed d = shadowsOf(deep, view);
    double worst = 0, lit_sum = 0, plain_sum = 0;
    for (int v = 0; v < d.mask.rows; ++v) {
      for (int u = 0; u < d.mask.cols; ++u) {
        if (!d.mask.at<uchar>(v, u)) continue;
        const cv::Vec3b a = d.lit.at<cv::Vec3b>(v, u), b = d.unshadowed.at<cv::Vec3b>(v, u);
        for (int k = 0; k < 3; ++k) {
          worst = std::max(worst, std::abs(a[k] - b[k] * (1 - depth)));
          lit_sum += a[k];
          plain_sum += b[k];
        }
      }
    }
    std::cout << "shadow_depth " << depth << ": the shadow keeps " << lit_sum / plain_sum
              << " of the light, each pixel within " << worst << " of " << 1 - depth << " x\n";
    EXPECT_LE(worst, 0.5 + 1e-9);
    EXPECT_NEAR(lit_sum / plain_sum, 1 - depth, 0.005);
    EXPECT_EQ(cv::countNonZero(d.mask), cv::countNonZero(s.mask));  // the same disc
  }
}

// An oblique light: the shadow's centre is where the ray from the sphere's centre away from the
// light meets the floor, and its outline the ellipse there (r across the light, r / |l_y| along).
TEST(Shadows, AnObliqueLightMovesTheShadowAlongTheRayFromTheCentre) {
  const ptz::CameraView view = StereoRig::makeDefault().view(Side::kLeft, {});
  const Eigen::Vector3d l = Eigen::Vector3d(0.5, -1, 0.3).normalized();
  const Scene scene = sphereScene(l);
  const Shadowed s = shadowsOf(scene, view);
  const Eigen::Vector3d c = scene.objects[0].trajectory.centre_m;
  const double r = scene.objects[0].radius_m;
  const Eigen::Vector3d foot = c + (kFloor_m - c.y()) / l.y() * l;
  ASSERT_GT(cv::countNonZero(s.mask), 500);
  const cv::Point2d mean = centroid(s.mask);
  const Eigen::Vector2d expected = view.project(foot);
  const Eigen::Vector2d area_centre = view.project(floorCentroid(s.mask, view, scene));
  // The ellipse's outline, projected: its box.
  const Eigen::Vector3d along = Eigen::Vector3d(l.x(), 0, l.z()).normalized();
  const Eigen::Vector3d across(-along.z(), 0, along.x());
  double u0 = 1e9, u1 = -1e9, v0 = 1e9, v1 = -1e9;
  for (int i = 0; i < 3600; ++i) {
    const double a = 2 * M_PI * i / 3600;
    const Eigen::Vector2d p =
        view.project(foot + r / -l.y() * std::cos(a) * along + r * std::sin(a) * across);
    u0 = std::min(u0, p.x());
    u1 = std::max(u1, p.x());
    v0 = std::min(v0, p.y());
    v1 = std::max(v1, p.y());
  }
  const cv::Rect box = cv::boundingRect(s.mask);
  std::cout << "oblique shadow: " << cv::countNonZero(s.mask) << " px, its area centroid at ("
            << area_centre.x() << ", " << area_centre.y() << ") against the foot of the ray ("
            << expected.x() << ", " << expected.y() << ") (its pixels' centroid at (" << mean.x
            << ", " << mean.y << ")); box " << box << " against u " << u0 << " .. " << u1 << ", v "
            << v0 << " .. " << v1 << "\n";
  EXPECT_NEAR(area_centre.x(), expected.x(), 0.5);
  EXPECT_NEAR(area_centre.y(), expected.y(), 0.5);
  EXPECT_NEAR(mean.x, expected.x(), 1.5);
  EXPECT_NEAR(mean.y, expected.y(), 2.0);  // the near half is larger in the image
  EXPECT_NEAR(box.x, u0, 1.0);
  EXPECT_NEAR(box.x + box.width - 1, u1, 1.0);
  EXPECT_NEAR(box.y, v0, 1.0);
  EXPECT_NEAR(box.y + box.height - 1, v1, 1.0);
}

// The lit side turns with the light: a matte sphere's brightest pixels (the red at 255, where its
// normal is within 5 degrees of the light) are around the projection of centre + r * direction,
// at each keyframe and half-way between, as the config text sets them.
TEST(LightDirection, TheBrightestPixelsOfAMatteSphereFaceTheLight) {
  const ptz::CameraView view = StereoRig::makeDefault().view(Side::kLeft, {});
  Scene scene;
  scene.objects.push_back(sphere({0, -0.2, 3}, 0.5, {0, 0, 255}));
  scene.light = ptz::test::lightFromText(
      "{ direction_s: [0, 2], direction: [[-0.5, -0.6, -0.6], [0.6, -0.3, -0.7]] }");
  const Eigen::Vector3d c = scene.objects[0].trajectory.centre_m;
  Renderer renderer(scene);
  for (const double t_s : {0.0, 1.0, 2.0}) {
    cv::Mat img;
    renderer.render(view, t_s, &img);
    cv::Mat brightest;
    cv::inRange(img, cv::Scalar(0, 0, 255), cv::Scalar(0, 0, 255), brightest);
    ASSERT_GT(cv::countNonZero(brightest), 0) << t_s;
    const cv::Point2d mean = centroid(brightest);
    const Eigen::Vector3d l = scene.light.toLightAt(t_s);
    const Eigen::Vector2d expected = view.project(c + 0.5 * l);
    std::cout << "t = " << t_s << " s: " << cv::countNonZero(brightest)
              << " px at 255, centred at (" << mean.x << ", " << mean.y << "), centre + r l at ("
              << expected.x() << ", " << expected.y() << ")\n";
    EXPECT_NEAR(mean.x, expected.x(), 2.0) << t_s;
    EXPECT_NEAR(mean.y, expected.y(), 2.0) << t_s;
  }
}

// A green box between the cameras and the sphere's shadow is drawn over it: its pixels are the
// same with shadows and without, the shadow's other pixels as without the box.
TEST(Shadows, AnObjectInFrontHidesTheShadow) {
  const ptz::CameraView view = StereoRig::makeDefault().view(Side::kLeft, {});
  const Scene alone = sphereScene({0, -1, 0});
  const Shadowed s = shadowsOf(alone, view);
  Scene screened = alone;
  SceneObject box;
  box.shape = SceneObject::Shape::kBox;
  box.half_extents_m = {0.15, 0.04, 0.02};
  box.color_bgr = {0, 255, 0};
  box.trajectory.centre_m = {0.2, 0.36, 1.5};  // on the way from the cameras to the shadow
  screened.objects.push_back(box);
  const Shadowed b = shadowsOf(screened, view);
  cv::Mat green;
  cv::inRange(b.lit, cv::Scalar(0, 1, 0), cv::Scalar(0, 255, 0), green);
  cv::Mat hidden = s.mask & green, shown = s.mask & ~green;
  std::cout << "the sphere's shadow " << cv::countNonZero(s.mask) << " px, behind the box "
            << cv::countNonZero(hidden) << "\n";
  ASSERT_GT(cv::countNonZero(hidden), 100);
  ASSERT_GT(cv::countNonZero(shown), 100);
  EXPECT_EQ(cv::countNonZero(differing(b.lit, b.unshadowed) & green), 0);
  EXPECT_EQ(cv::countNonZero(differing(b.lit, s.lit) & shown), 0);
}

// A walking person's figure casts its own outline: in the light from behind the cameras at 45
// degrees, its shadow on the floor starts at its feet and is as long as it is tall.
TEST(Shadows, APersonCastsItsOutline) {
  const StereoRig rig = StereoRig::makeDefault();
  const ptz::CameraView view = rig.view(Side::kLeft, {});
  Scene scene;  // the floor at 1.4 m
  SceneObject person;
  person.shape = SceneObject::Shape::kPerson;
  person.color_bgr = {40, 160, 40};
  person.trajectory.centre_m = {0.3, scene.floor_height_m - person.height_m / 2, 4};
  scene.objects.push_back(person);
  scene.light.direction_s = {0};
  scene.light.direction = {Eigen::Vector3d(0, -1, -1).normalized()};
  const Shadowed s = shadowsOf(scene, view);
  ASSERT_GT(cv::countNonZero(s.mask), 200);
  // Each shadowed pixel's floor point: within the figure's width, behind it by at most its height.
  Renderer renderer(scene);
  const cv::Mat& rays = renderer.rays(view);
  double x0 = 1e9, x1 = -1e9, z0 = 1e9, z1 = -1e9;
  for (int v = 0; v < s.mask.rows; ++v) {
    for (int u = 0; u < s.mask.cols; ++u) {
      if (!s.mask.at<uchar>(v, u)) continue;
      const cv::Vec2f ray = rays.at<cv::Vec2f>(v, u);
      const Eigen::Vector3d d = view.rotation_head_camera * Eigen::Vector3d(ray[0], ray[1], 1);
      const Eigen::Vector3d p =
          view.position_head_m + (scene.floor_height_m - view.position_head_m.y()) / d.y() * d;
      x0 = std::min(x0, p.x());
      x1 = std::max(x1, p.x());
      z0 = std::min(z0, p.z());
      z1 = std::max(z1, p.z());
    }
  }
  std::cout << "the person's shadow: " << cv::countNonZero(s.mask) << " px, x " << x0 << " .. "
            << x1 << ", z " << z0 << " .. " << z1 << "\n";
  EXPECT_GE(x0, 0.3 - person.height_m / 4 - 0.01);
  EXPECT_LE(x1, 0.3 + person.height_m / 4 + 0.01);
  EXPECT_GE(z0, 4 - 0.01);
  EXPECT_LE(z1, 4 + person.height_m + 0.01);
  EXPECT_GT(z1, 4 + 0.9 * person.height_m);  // the head's shadow is seen
}

// Shadows move with the objects: drawn on each image, never into the kept background; any band
// count gives the same bytes.
TEST(Shadows, KeptBackgroundAndBandsGiveTheSameBytes) {
  const ptz::CameraView view = StereoRig::makeDefault().view(Side::kLeft, {0.05, 0.1, 1.2});
  Scene scene = sphereScene(Eigen::Vector3d(0.3, -1, -0.2));
  scene.light.shadows = true;
  scene.objects[0].trajectory.type = ptz::sim::Trajectory::Type::kLine;
  scene.objects[0].trajectory.amplitude_m = {0.5, 0, 0.3};
  SceneObject box;
  box.shape = SceneObject::Shape::kBox;
  box.half_extents_m = {0.2, 0.1, 0.15};
  box.yaw_rate_rad_s = 1;
  box.trajectory.centre_m = {-0.3, 0.2, 2.2};
  scene.objects.push_back(box);
  scene.chessboard.present = true;  // standing on the floor, in front of the shadows' floor
  scene.chessboard.centre_head_m = {0.5, 0.35, 2.3};
  Renderer kept(scene);
  cv::Mat img;
  for (const double t_s : {0.0, 0.0, 0.0, 1.5, 3.0}) {  // kept from the second
    kept.render(view, t_s, &img);
    Renderer fresh(scene);
    cv::Mat expected;
    fresh.render(view, t_s, &expected);
    EXPECT_EQ(cv::norm(img, expected, cv::NORM_INF), 0) << "t = " << t_s;
    for (const int bands : {1, 7}) {
      Renderer banded(scene);
      banded.setBands(bands);
      cv::Mat b;
      banded.render(view, t_s, &b);
      EXPECT_EQ(cv::norm(b, expected, cv::NORM_INF), 0) << bands << " bands, t = " << t_s;
    }
  }
}

// What shadows cost a VGA frame: three objects and their shadows in view (about 4200 shadowed
// pixels), the view still (the background kept) and moving; on one thread, the median of 60.
TEST(Shadows, CostAtVga) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene = sphereScene(Eigen::Vector3d(0.3, -1, -0.2));
  scene.objects.push_back(sphere({-0.6, 0.2, 3}, 0.2, {200, 0, 0}));
  SceneObject box;
  box.shape = SceneObject::Shape::kBox;
  box.half_extents_m = {0.2, 0.1, 0.15};
  box.trajectory.centre_m = {-0.3, 0.2, 2.2};
  scene.objects.push_back(box);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const auto timed = [&](bool shadows, bool moving) {
    Scene s = scene;
    s.light.shadows = shadows;
    Renderer renderer(s);
    cv::Mat img;
    std::vector<double> ms;
    for (int k = 0; k < 62; ++k) {
      const ptz::CameraView view = rig.view(Side::kLeft, {moving ? 0.001 * k : 0, 0, 1});
      const auto start = std::chrono::steady_clock::now();
      renderer.render(view, k / 30.0, &img);
      const auto end = std::chrono::steady_clock::now();
      if (k >= 2) ms.push_back(std::chrono::duration<double, std::milli>(end - start).count());
    }
    std::nth_element(ms.begin(), ms.begin() + ms.size() / 2, ms.end());
    return ms[ms.size() / 2];
  };
  const Shadowed shadowed = shadowsOf(scene, rig.view(Side::kLeft, {}));
  for (const bool moving : {false, true}) {
    const double off = timed(false, moving), on = timed(true, moving);
    std::cout << (moving ? "moving" : "still") << " view at VGA, 3 objects, "
              << cv::countNonZero(shadowed.mask) << " px in shadow, one thread: " << off
              << " ms without shadows, " << on << " ms with (medians of 60)\n";
  }
  cv::setNumThreads(threads);
}

TEST(LightDirection, BadValuesAreNamed) {
  const auto expectIn = [](const std::string& map, const std::string& part) {
    const std::string m = lightError(map);
    EXPECT_NE(m.find(part), std::string::npos) << map << " -> " << m;
    EXPECT_NE(m.find("light.yaml"), std::string::npos) << m;
  };
  expectIn("{ direction_s: [0, 1], direction: [[0, -1, 0], [0, 0, 0]] }",
           "light.direction[1]: must not be zero, got [0, 0, 0]");
  expectIn("{ direction: [0, 0, 0] }", "light.direction: must not be zero, got [0, 0, 0]");
  expectIn("{ direction_s: [0, 1], direction: [[0, -1, 0]] }", "1 directions for 2 times");
  expectIn("{ direction_s: [1, 0], direction: [[0, -1, 0], [1, -1, 0]] }",
           "direction_s: times must increase");
  expectIn("{ direction_s: [0, 1], direction: [[0, -1, 0], [0, 1]] }",
           "light.direction[1]: must be [x, y, z]");
  expectIn("{ direction_s: [0, 1], direction: [[0, -1, 0], [0, 1, 0]] }",
           "light.direction[1]: opposite to the one before");
  expectIn("{ direction_s: [0, 1], direction: [[0, -1, 0], [0, \"up\", 0]] }",
           "light.direction[1]: must be [x, y, z]");
  expectIn("{ direction: [[0, -1, 0], [0, -1, 1]] }", "direction_s");
  expectIn("{ shadow_depth: 1.5 }", "light.shadow_depth");
  expectIn("{ shadow_depth: -0.1 }", "light.shadow_depth");
  expectIn("{ shadows: maybe }", "light.shadows: must be true or false, got 'maybe'");
  expectIn("{ shadows: 2 }", "light.shadows: must be true or false, got 2");
  expectIn("{ shadow: true }", "light.shadow: unknown field");
  EXPECT_TRUE(ptz::test::lightFromText("{ shadows: true }").shadows);
  EXPECT_TRUE(ptz::test::lightFromText("{ shadows: 1 }").shadows);
  EXPECT_FALSE(ptz::test::lightFromText("{ shadows: false }").shadows);
}
