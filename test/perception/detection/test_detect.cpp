// Detection and triangulation on rendered frames with known truth, and segmentation on a photo.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>

#include "perception/detection/detector.hpp"
#include "perception/detection/stereo.hpp"
#include "sim/simulator.hpp"
#include "support/data_dir.hpp"
#include "support/detect_scene.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace perception = ptz::perception;
namespace sim = ptz::sim;
using ptz::test::defaultClasses;
using ptz::test::kGreen;
using ptz::test::kRed;
using ptz::test::object;

namespace {

const cv::Vec3b kYellow(30, 200, 220);

// Renders a frame of `scene` with both cameras at `left`/`right` (motors settled at once).
sim::SimFrame render(const StereoRig& rig, const sim::Scene& scene, const PtzPose& left,
                     const PtzPose& right) {
  auto plant = ptz::defaultPlantParams();
  for (auto& a : plant.axis) {
    a.time_constant_s = 1e-4;
    a.max_rate_per_s = 1e6;
  }
  sim::Simulator s(rig, scene, plant, 2.0, 3);
  int clamped = 0, rejected = 0;
  s.command(0, left, right, &clamped, &rejected);
  s.advanceTo(0.05);
  return s.capture();
}

int classIndex(const perception::DetectorParams& p, const std::string& name) {
  for (size_t i = 0; i < p.classes.size(); ++i) {
    if (p.classes[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

// Points both cameras at p (pan from atan2 of x and z, tilt from y) and zooms.
std::pair<PtzPose, PtzPose> lookAt(const Eigen::Vector3d& p, double zoom, double miss_rad) {
  const double pan = std::atan2(p.x(), p.z()) + miss_rad;
  const double tilt = std::atan2(-p.y(), std::hypot(p.x(), p.z())) - miss_rad / 2;
  return {{pan, tilt, zoom}, {pan - 0.02, tilt, zoom}};
}

}  // namespace

TEST(Detector, CentroidIsTheProjectionOfTheTrueCentreWithinOnePixel) {
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  const int red = classIndex(detector.params(), "red_ball");
  const std::vector<std::pair<Eigen::Vector3d, PtzPose>> cases = {
      {{0.0, 0.0, 3.0}, {0, 0, 1}},          {{1.0, -0.4, 2.5}, {0, 0, 1}},
      {{-0.8, 0.5, 2.0}, {-0.2, -0.1, 1}},   {{0.6, 0.1, 4.5}, {0.15, 0, 3}},
      {{-0.3, -0.2, 1.5}, {-0.1, 0.1, 1.5}},
  };
  for (const auto& [p, pose] : cases) {
    sim::Scene scene;
    scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, p, kRed)};
    const sim::SimFrame f = render(rig, scene, pose, pose);
    for (Side side : {Side::kLeft, Side::kRight}) {
      const auto regions = detector.detect(side == Side::kLeft ? f.left : f.right);
      ASSERT_EQ(regions.size(), 1u) << p.transpose() << " " << ptz::sideName(side);
      EXPECT_EQ(regions[0].class_index, red);
      const Eigen::Vector2d truth = rig.view(side, pose).project(p);
      EXPECT_NEAR(regions[0].centroid_px.x, truth.x(), 1.0) << ptz::sideName(side) << p.transpose();
      EXPECT_NEAR(regions[0].centroid_px.y, truth.y(), 1.0) << ptz::sideName(side) << p.transpose();
    }
  }
}

// Two red balls overlapping in the image, one 0.6 m behind the other and partly hidden, make
// one blob: it is split into their discs, each centred on its ball's projection (the hidden one
// from its visible arc), both marked split, the front one with more of its circle seen.
TEST(Detector, OverlappingBallsOfOneClassAreSplitIntoTheirDiscs) {
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  const Eigen::Vector3d front(0.0, 0.05, 2.4), back(0.16, 0.0, 3.0);
  sim::Scene scene;
  scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, front, kRed),
                   object("red_ball", sim::SceneObject::Shape::kSphere, back, kRed)};
  const sim::SimFrame f = render(rig, scene, {}, {});
  for (Side side : {Side::kLeft, Side::kRight}) {
    const auto regions = detector.detect(side == Side::kLeft ? f.left : f.right);
    ASSERT_EQ(regions.size(), 2u) << ptz::sideName(side);
    std::vector<double> arcs;
    for (const auto& [p, tol_px] : {std::pair{front, 1.0}, std::pair{back, 1.5}}) {
      const Eigen::Vector2d truth = rig.view(side, {}).project(p);
      const perception::Region* nearest = &regions[0];
      for (const auto& r : regions) {
        if (std::hypot(r.centroid_px.x - truth.x(), r.centroid_px.y - truth.y()) <
            std::hypot(nearest->centroid_px.x - truth.x(), nearest->centroid_px.y - truth.y())) {
          nearest = &r;
        }
      }
      EXPECT_TRUE(nearest->split());
      EXPECT_NEAR(nearest->centroid_px.x, truth.x(), tol_px) << ptz::sideName(side);
      EXPECT_NEAR(nearest->centroid_px.y, truth.y(), tol_px) << ptz::sideName(side);
      arcs.push_back(nearest->arc_fraction);
    }
    // The front ball's circle is on the blob's outline but where the other shows beside it.
    EXPECT_GT(arcs[0], arcs[1]) << ptz::sideName(side);
    EXPECT_GT(arcs[1], 0.4) << ptz::sideName(side);
  }
}

TEST(Detector, RejectsAWrongColourAndAWrongShapeOfSimilarSize) {
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  const int red = classIndex(detector.params(), "red_ball");
  sim::Scene scene;
  const Eigen::Vector3d ball(-0.4, 0.0, 2.5);
  scene.objects = {
      object("red_ball", sim::SceneObject::Shape::kSphere, ball, kRed),
      // A red cube of the ball's size, face on: right colour, wrong shape.
      object("red_box", sim::SceneObject::Shape::kBox, {0.4, 0.0, 2.5}, kRed),
      // A yellow ball of the same size: right shape, wrong colour.
      object("yellow_ball", sim::SceneObject::Shape::kSphere, {0.0, 0.3, 2.5}, kYellow),
  };
  const sim::SimFrame f = render(rig, scene, {}, {});
  const auto regions = detector.detect(f.left);
  int reds = 0;
  for (const auto& r : regions) {
    if (r.class_index != red) continue;
    ++reds;
    const Eigen::Vector2d truth = rig.view(Side::kLeft, {}).project(ball);
    EXPECT_NEAR(r.centroid_px.x, truth.x(), 1.0);
  }
  EXPECT_EQ(reds, 1);
  // The cube's silhouette is there in the mask: it was its shape that failed.
  const cv::Mat mask = detector.mask(f.left, static_cast<size_t>(red));
  const Eigen::Vector2d cube = rig.view(Side::kLeft, {}).project({0.4, 0.0, 2.5});
  EXPECT_GT(mask.at<uchar>(static_cast<int>(cube.y()), static_cast<int>(cube.x())), 0);
}

TEST(Stereo, StaticObjectsAt1To5MetresWithinHalfAPercentOfRange) {
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> range(1.0, 5.0), bearing(-0.5, 0.5), elev(-0.25, 0.25),
      miss(-0.12, 0.12), zoom(1.0, 3.0);
  double worst_pct = 0;
  for (int i = 0; i < 16; ++i) {
    const double r = range(rng), az = bearing(rng), el = elev(rng);
    const Eigen::Vector3d p(r * std::cos(el) * std::sin(az), -r * std::sin(el),
                            r * std::cos(el) * std::cos(az));
    // Cameras panned, tilted and zoomed to different poses: some look at it, some past it.
    const auto [lp, rp] = lookAt(p, i % 4 == 0 ? 1.0 : zoom(rng), miss(rng) / (i % 4 == 0 ? 1 : 4));
    sim::Scene scene;
    scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, p, kRed)};
    const sim::SimFrame f = render(rig, scene, lp, rp);
    const auto lr = detector.detect(f.left), rr = detector.detect(f.right);
    const auto objects =
        perception::associate(lr, rr, rig.view(Side::kLeft, lp), rig.view(Side::kRight, rp), {});
    ASSERT_EQ(objects.size(), 1u) << "case " << i << " at " << p.transpose();
    const double err = (objects[0].position_head_m - p).norm();
    worst_pct = std::max(worst_pct, 100 * err / r);
    EXPECT_LE(err, 0.005 * r) << "case " << i << " range " << r << " zoom " << lp.zoom;
    // The covariance says how far off it may be: the error within 4 sigma along its worst axis.
    const double sigma = std::sqrt(objects[0].covariance_m2.eigenvalues().real().maxCoeff());
    EXPECT_GT(sigma, 0);
    EXPECT_LT(err, 4 * sigma + 0.002) << "case " << i;
  }
  std::printf("worst 3D error: %.3f %% of range\n", worst_pct);
}

TEST(Stereo, TriangulationIsExactForNoiselessPixels) {
  const StereoRig rig = StereoRig::makeDefault();
  const Eigen::Vector3d p(0.4, -0.3, 3.7);
  const PtzPose lp{0.2, 0.05, 2.0}, rp{0.1, 0.08, 2.5};
  const auto lv = rig.view(Side::kLeft, lp), rv = rig.view(Side::kRight, rp);
  Eigen::Vector3d q;
  double epi = -1;
  ASSERT_TRUE(perception::triangulate(lv, rv, lv.project(p), rv.project(p), &q, &epi));
  EXPECT_LT((q - p).norm(), 1e-6);
  EXPECT_LT(epi, 1e-3);
  // Off the epipolar line by 5 px vertically: reported as about 5 px.
  ASSERT_TRUE(perception::triangulate(lv, rv, lv.project(p), rv.project(p) + Eigen::Vector2d(0, 5),
                                      &q, &epi));
  EXPECT_NEAR(epi, 5.0, 1.0);
}

TEST(Detector, CountsTheRedAndBlueSmartiesInTheRealPhoto) {
  const std::string path = ptz::test::dataDir() + "/color/smarties.png";
  PTZ_REQUIRE_DATA(path);
  const cv::Mat img = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  perception::DetectorParams p;
  perception::ColorClass red;
  red.name = "red";
  red.hue_min_deg = 345;
  red.hue_max_deg = 10;
  // HSI saturation of a bright blue with equal red and green is under 0.5: a lower bound.
  red.saturation_min = 0.35;
  red.shape = "circle";
  // Highlights and shading cut into real candies' silhouettes: a looser shape match.
  red.max_shape_distance = 0.08;
  red.min_area_px2 = 400;
  perception::ColorClass blue = red;
  blue.name = "blue";
  blue.hue_min_deg = 195;
  blue.hue_max_deg = 270;
  p.classes = {red, blue};
  const perception::Detector detector(p);
  // Counted and located by eye: four red (the two orange ones are not red), three blue.
  const std::vector<cv::Point2d> red_at = {{33, 228}, {98, 258}, {287, 213}, {220, 305}};
  const std::vector<cv::Point2d> blue_at = {{377, 80}, {347, 237}, {293, 320}};
  int reds = 0, blues = 0;
  for (const auto& r : detector.detect(img)) {
    const auto& expected = r.class_index == 0 ? red_at : blue_at;
    (r.class_index == 0 ? reds : blues)++;
    double nearest = 1e9;
    for (const auto& e : expected) nearest = std::min(nearest, cv::norm(r.centroid_px - e));
    EXPECT_LT(nearest, 10.0) << "a " << (r.class_index == 0 ? "red" : "blue") << " region at "
                             << r.centroid_px << " where there is no such candy";
  }
  EXPECT_EQ(reds, 4);
  EXPECT_EQ(blues, 3);
}
