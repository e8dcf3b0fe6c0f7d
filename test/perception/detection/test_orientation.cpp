// A box's yaw from both views' outlines, on frames rendered by the simulator at a known yaw
// (JPEG-compressed as ptz-sim sends them), 1-4 m, several zooms.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "perception/detection/detector.hpp"
#include "perception/detection/orientation.hpp"
#include "perception/detection/stereo.hpp"
#include "perception/tracking/yaw.hpp"
#include "sim/simulator.hpp"
#include "support/detect_scene.hpp"
#include "support/render_aimed.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace perception = ptz::perception;
namespace sim = ptz::sim;
using ptz::test::defaultClasses;

namespace {

int classIndex(const perception::DetectorParams& p, const std::string& name) {
  for (size_t i = 0; i < p.classes.size(); ++i) {
    if (p.classes[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

struct Case {
  Eigen::Vector3d centre;
  double yaw_deg;
  double zoom;
  double half_m;  // half extent of the cube
};

struct Result {
  bool found = false;  // both views detected and paired
  bool cut = false;    // by an image border in either view
  perception::BoxYaw yaw;
  double error_deg = 0;
  double us = 0;
};

// Renders the box, detects and pairs it, and estimates its yaw with the frame's own views.
Result run(const Case& c, const perception::Detector& detector) {
  const StereoRig rig = StereoRig::makeDefault();
  sim::Scene scene;
  sim::SceneObject box;
  box.name = "box";
  box.class_name = "green_box";
  box.shape = sim::SceneObject::Shape::kBox;
  box.half_extents_m = Eigen::Vector3d::Constant(c.half_m);
  box.yaw_rad = c.yaw_deg * M_PI / 180;
  box.color_bgr = {40, 170, 40};
  box.trajectory.centre_m = c.centre;
  scene.objects = {box};
  const ptz::test::AimedFrame f = ptz::test::renderAimed(rig, scene, c.centre, c.zoom);
  const cv::Mat &left = f.left, &right = f.right;
  const ptz::CameraView &lv = f.left_view, &rv = f.right_view;
  const auto lr = detector.detect(left), rr = detector.detect(right);
  const auto objects = perception::associate(lr, rr, lv, rv, {});
  Result out;
  const int green = classIndex(detector.params(), "green_box");
  for (const auto& o : objects) {
    if (o.class_index != green) continue;
    out.found = true;
    const auto& l = lr[static_cast<size_t>(o.left)];
    const auto& r = rr[static_cast<size_t>(o.right)];
    // ptz-detect does not estimate from a region an image border cuts.
    out.cut =
        perception::regionCut(l.bbox, left.size()) || perception::regionCut(r.bbox, right.size());
    const cv::Rect lc = perception::boxCrop(l.bbox, left.size(), 8);
    const cv::Rect rc = perception::boxCrop(r.bbox, right.size(), 8);
    const auto t0 = std::chrono::steady_clock::now();
    const perception::BoxView bl = perception::makeBoxView(detector, static_cast<size_t>(green),
                                                           left(lc), lc.tl(), l.bbox, lv);
    const perception::BoxView br = perception::makeBoxView(detector, static_cast<size_t>(green),
                                                           right(rc), rc.tl(), r.bbox, rv);
    out.yaw = perception::estimateBoxYaw(bl, br, o.position_head_m);
    out.us =
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    out.error_deg = perception::wrapAngle(out.yaw.yaw_rad - box.yaw_rad, M_PI / 2) * 180 / M_PI;
    break;
  }
  return out;
}

}  // namespace

TEST(Orientation, WrapAndQuaternion) {
  EXPECT_NEAR(perception::wrapAngle(0.8, M_PI / 2), 0.8 - M_PI / 2, 1e-12);
  EXPECT_NEAR(perception::wrapAngle(-0.8, M_PI / 2), -0.8 + M_PI / 2, 1e-12);
  EXPECT_NEAR(perception::wrapAngle(-M_PI / 4, M_PI / 2), -M_PI / 4, 1e-12);
  EXPECT_NEAR(perception::wrapAngle(M_PI / 4, M_PI / 2), -M_PI / 4, 1e-12);
  EXPECT_NEAR(perception::wrapAngle(3.0, 2 * M_PI), 3.0, 1e-12);
  // The quaternion turns the box's +x towards the head's -z for a positive yaw, as the renderer.
  const Eigen::Vector4d q = perception::yawQuaternionWxyz(0.3);
  const Eigen::Quaterniond qe(q[0], q[1], q[2], q[3]);
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_LT((qe.toRotationMatrix() - expected).norm(), 1e-12);
}

TEST(Orientation, SpheresHaveNoneBoxesDo) {
  const perception::DetectorParams p = defaultClasses();
  for (const auto& c : p.classes) {
    EXPECT_EQ(perception::classHasOrientation(c), c.name == "green_box") << c.name;
  }
}

// Boxes at known yaws, 1-4 m, zooms 1-3, above, level with and below the cameras: RMS error
// within 5 degrees over all, each case within its bound, the sigma not far too small.
TEST(Orientation, BoxYawFromBothOutlinesWithin5DegreesRms) {
  const perception::Detector detector(defaultClasses());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> yaw(-45, 45), range(1.0, 4.0), bearing(-0.3, 0.3),
      height(0.1, 0.5), zoom(1.0, 3.0);
  std::vector<Case> cases;
  for (int i = 0; i < 24; ++i) {
    const double r = range(rng), az = bearing(rng);
    // Mostly below the cameras (on a floor), some level with them: no top face seen.
    const double y = i % 6 == 5 ? 0.0 : height(rng);
    cases.push_back({{r * std::sin(az), y, r * std::cos(az)},
                     yaw(rng),
                     i % 3 == 0 ? 1.0 : zoom(rng),
                     i % 2 == 0 ? 0.15 : 0.1});
  }
  // The hardest: a face on (0) and a corner on (44), and either side of the wrap.
  cases.push_back({{0, 0.3, 2.0}, 0.0, 1.0, 0.15});
  cases.push_back({{0, 0.3, 2.0}, 44.0, 1.0, 0.15});
  cases.push_back({{0.3, 0.4, 3.5}, -44.0, 2.0, 0.15});
  double sum2 = 0, worst = 0, sum_us = 0, sum_z2 = 0;
  int n = 0;
  for (const Case& c : cases) {
    const Result r = run(c, detector);
    ASSERT_TRUE(r.found) << c.centre.transpose();
    ASSERT_FALSE(r.cut) << c.centre.transpose();
    ASSERT_TRUE(r.yaw.ok) << c.centre.transpose() << ": " << r.yaw.why;
    std::printf(
        "  range %.2f m  y %.2f  zoom %.2f  yaw %6.1f  error %6.2f deg  sigma %.2f  cost %.3f"
        "  %s %d evals %.0f us\n",
        c.centre.norm(), c.centre.y(), c.zoom, c.yaw_deg, r.error_deg,
        std::sqrt(r.yaw.variance_rad2) * 180 / M_PI, r.yaw.cost,
        r.yaw.mirror_decided ? "mirror" : "      ", r.yaw.evaluations, r.us);
    // A case: no mirror mistake (those are off by 2 x the relative yaw, tens of degrees).
    EXPECT_LT(std::abs(r.error_deg), 10.0) << c.centre.transpose() << " yaw " << c.yaw_deg;
    sum2 += r.error_deg * r.error_deg;
    sum_z2 += std::pow(r.error_deg * M_PI / 180, 2) / r.yaw.variance_rad2;
    worst = std::max(worst, std::abs(r.error_deg));
    sum_us += r.us;
    ++n;
  }
  const double rms = std::sqrt(sum2 / n);
  std::printf("  %d boxes: RMS %.2f deg, worst %.2f deg, RMS error/sigma %.2f, mean %.0f us\n", n,
              rms, worst, std::sqrt(sum_z2 / n), sum_us / n);
  EXPECT_LT(rms, 5.0);
  // The sigma is of the right size: errors within a few sigma on average.
  EXPECT_LT(std::sqrt(sum_z2 / n), 4.0);
}

TEST(Orientation, NoEstimateWithoutARegion) {
  perception::BoxView empty;
  empty.mask = cv::Mat::zeros(20, 20, CV_8U);
  empty.gray = cv::Mat::zeros(20, 20, CV_8U);
  const perception::BoxYaw y = perception::estimateBoxYaw(empty, empty, {0, 0, 2});
  EXPECT_FALSE(y.ok);
}
