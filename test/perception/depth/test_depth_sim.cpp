// ptz-depth's library on rendered frames of the true rig, against the scene's exact geometry:
// depth of backdrop and floor points (VGA, and 1080p matched decimated), the points' colours, and
// the radius of a sphere fitted to its cloud.
#include <gtest/gtest.h>
#include <pcl/ModelCoefficients.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/sac_segmentation.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>
#include <utility>

#include "perception/depth/cloud.hpp"
#include "perception/depth/depth.hpp"
#include "sim/renderer.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace perception = ptz::perception;
namespace sim = ptz::sim;

namespace {

struct Pair {
  cv::Mat left, right;
};

// Both cameras rendered at their poses, with the simulator's pixel noise (sigma 2 grey levels).
Pair renderPair(const StereoRig& rig, const sim::Scene& scene, const PtzPose& left,
                const PtzPose& right) {
  sim::Renderer renderer(scene);
  Pair p;
  renderer.render(rig.view(Side::kLeft, left), 0.0, &p.left);
  renderer.render(rig.view(Side::kRight, right), 0.0, &p.right);
  const sim::NoiseBank noise(rig.left.width, rig.left.height, 2.0, 5);
  noise.apply(0, 0, &p.left);
  noise.apply(0, 1, &p.right);
  return p;
}

// Distance along the ray from `origin` through `point` to the first backdrop or floor hit.
double trueRange(const sim::Scene& scene, const Eigen::Vector3d& origin,
                 const Eigen::Vector3d& point) {
  const Eigen::Vector3d dir = (point - origin).normalized();
  double t = std::numeric_limits<double>::infinity();
  if (dir.z() > 0) t = (scene.backdrop_distance_m - origin.z()) / dir.z();
  if (dir.y() > 0) t = std::min(t, (scene.floor_height_m - origin.y()) / dir.y());
  return t;
}

struct Case {
  const char* name;
  PtzPose left, right;
};

// Home; panned and tilted with the cameras verging on a point about 6 m ahead; verging on a point
// 1.5 m ahead, so everything behind it has a negative disparity.
const Case kCases[] = {
    {"home", {0, 0, 1}, {0, 0, 1}},
    {"panned_verged", {0.15, 0.05, 1}, {0.10, 0.05, 1}},
    {"strongly_verged", {0.10, 0, 1}, {-0.10, 0, 1}},
};

// The points of the cloud ptz-depth makes of a pair rendered at the case's poses.
std::vector<cv::Point3f> cloudOf(const StereoRig& rig, const Pair& pair, const Case& c,
                                 const perception::DepthParams& depth_params,
                                 const perception::CloudParams& cloud_params) {
  perception::DepthEstimator estimator(rig, depth_params);
  perception::DepthFrame frame;
  std::string why;
  std::vector<cv::Point3f> points;
  if (!estimator.process(pair.left, pair.right, c.left, c.right, std::nullopt, &frame, &why)) {
    ADD_FAILURE() << c.name << ": " << why;
    return points;
  }
  EXPECT_TRUE(perception::cloudPoints(
      perception::makeCloud(frame.points_head_m, frame.colours_bgr, cloud_params), &points));
  return points;
}

sim::Scene backdropAndFloor() {
  sim::Scene scene;
  scene.backdrop_distance_m = 4.8;
  scene.floor_height_m = 1.0;  // seen from about 2 m on
  return scene;
}

// Depth error along the ray of the cloud's points 2-5 m away, relative, RMS; how many there are.
double depthErrorRms(const sim::Scene& scene, const Eigen::Vector3d& origin,
                     const std::vector<cv::Point3f>& points, int* n) {
  double sum_sq = 0;
  *n = 0;
  for (const auto& p : points) {
    const Eigen::Vector3d q(p.x, p.y, p.z);
    const double truth = trueRange(scene, origin, q);
    if (truth < 2.0 || truth > 5.0) continue;
    const double rel = ((q - origin).norm() - truth) / truth;
    sum_sq += rel * rel;
    ++*n;
  }
  return std::sqrt(sum_sq / *n);
}

// The backdrop and floor through ptz-depth at every case's poses with both matchers: within 1 %
// RMS with enough points.
void checkBackdropAndFloor(const StereoRig& rig, const char* size,
                           const perception::DepthParams& params) {
  const sim::Scene scene = backdropAndFloor();
  using Mode = perception::MatcherParams::Mode;
  for (const Case& c : kCases) {
    const Pair pair = renderPair(rig, scene, c.left, c.right);
    for (Mode mode : {Mode::kBm, Mode::kSgbm}) {
      perception::DepthParams dp = params;
      dp.matcher.mode = mode;
      const std::vector<cv::Point3f> points = cloudOf(rig, pair, c, dp, {});
      int n = 0;
      const double rms =
          depthErrorRms(scene, rig.view(Side::kLeft, c.left).position_head_m, points, &n);
      std::printf("%s %s %s: %zu cloud points, %d at 2-5 m, depth error %.3f %% RMS\n", size,
                  perception::MatcherParams::modeName(mode), c.name, points.size(), n, 100 * rms);
      EXPECT_GT(n, 1000) << size << " " << c.name;
      EXPECT_LT(rms, 0.01) << size << " " << c.name;
    }
  }
}

}  // namespace

TEST(DepthSim, BackdropAndFloorDepthWithinOnePercentRms) {
  checkBackdropAndFloor(StereoRig::makeDefault(), "VGA", {});
}

// 1080p frames are matched at 960 x 540 (match_max_width_px): the cloud in metres all the same,
// as accurate as VGA's. 96 disparities at 960 px cover the depths 64 cover at VGA (1.9-10 m).
TEST(DepthSim, DecimatedFullHdDepthWithinOnePercentRms) {
  const StereoRig rig = StereoRig::makeDefault().atSize(1920, 1080);
  perception::DepthParams dp;
  dp.matcher.num_disparities = 96;
  ASSERT_EQ(perception::DepthEstimator(rig, dp).decimation(), 2);
  checkBackdropAndFloor(rig, "1080p", dp);
}

// Each point's colour is the left image's at the pixel the point projects to (the samples'
// colours come from the input image through the rectification map, decimated or not). Whatever
// its depth, a point projects to where its sample came from; half a pixel off is ~1 grey level.
TEST(DepthSim, PointColoursAreTheLeftImagesAtTheirPixels) {
  const sim::Scene scene = backdropAndFloor();
  for (const auto& [w, h] : {std::pair{640, 480}, std::pair{1920, 1080}}) {
    const StereoRig rig = StereoRig::makeDefault().atSize(w, h);
    const Case& c = kCases[1];
    const Pair pair = renderPair(rig, scene, c.left, c.right);
    perception::DepthEstimator estimator(rig, {});
    perception::DepthFrame frame;
    std::string why;
    ASSERT_TRUE(
        estimator.process(pair.left, pair.right, c.left, c.right, std::nullopt, &frame, &why))
        << why;
    const ptz::CameraView view = rig.view(Side::kLeft, c.left);
    double sum = 0;
    int n = 0;
    for (size_t i = 0; i < frame.points_head_m.size(); ++i) {
      const cv::Point3f& p = frame.points_head_m[i];
      const Eigen::Vector2d px = view.project({p.x, p.y, p.z});
      if (!(px.x() >= 0 && px.y() >= 0 && px.x() < w - 1 && px.y() < h - 1)) continue;
      cv::Mat colour;
      cv::getRectSubPix(pair.left, {1, 1}, cv::Point2f(px.x(), px.y()), colour);
      sum += cv::norm(cv::Vec3d(colour.at<cv::Vec3b>(0, 0)) - cv::Vec3d(frame.colours_bgr[i]),
                      cv::NORM_L1) /
             3;
      ++n;
    }
    const double mean = sum / n;
    std::printf("%dx%d: %d points, colour off by %.2f grey levels on average\n", w, h, n, mean);
    EXPECT_GT(n, 1000);
    EXPECT_LT(mean, 0.3) << w << "x" << h;
  }
}

TEST(DepthSim, SphereCloudFitsTheTrueRadiusWithinFivePercent) {
  const StereoRig rig = StereoRig::makeDefault();
  sim::Scene scene;
  scene.backdrop_distance_m = 4.8;
  scene.floor_height_m = 1.0;
  sim::SceneObject ball;
  ball.name = "ball";
  ball.radius_m = 0.3;
  ball.color_bgr = {40, 60, 200};
  ball.textured = true;
  ball.trajectory.centre_m = {0.3, 0.1, 2.4};  // in front of both poses' views
  scene.objects.push_back(ball);
  using Mode = perception::MatcherParams::Mode;
  for (Mode mode : {Mode::kBm, Mode::kSgbm}) {
    for (const Case& c : kCases) {
      perception::DepthParams dp;
      dp.matcher.mode = mode;
      dp.cloud_stride_px = 1;
      // Every pixel and a finer voxel than the process's default: the fit needs the limb.
      perception::CloudParams cp;
      cp.voxel_size_m = 0.005;
      const std::vector<cv::Point3f> points =
          cloudOf(rig, renderPair(rig, scene, c.left, c.right), c, dp, cp);
      // The points near the ball (the truth only selects the region; the fit finds the sphere).
      pcl::PointCloud<pcl::PointXYZ>::Ptr near(new pcl::PointCloud<pcl::PointXYZ>);
      for (const auto& p : points) {
        if ((Eigen::Vector3d(p.x, p.y, p.z) - ball.trajectory.centre_m).norm() <
            1.5 * ball.radius_m)
          near->push_back({p.x, p.y, p.z});
      }
      ASSERT_GT(near->size(), 200u) << c.name;
      pcl::SACSegmentation<pcl::PointXYZ> sac;
      sac.setModelType(pcl::SACMODEL_SPHERE);
      sac.setMethodType(pcl::SAC_RANSAC);
      sac.setDistanceThreshold(0.01);
      sac.setMaxIterations(5000);
      sac.setOptimizeCoefficients(true);
      sac.setRadiusLimits(0.05, 1.0);
      sac.setInputCloud(near);
      pcl::PointIndices inliers;
      pcl::ModelCoefficients sphere;
      sac.segment(inliers, sphere);
      ASSERT_EQ(sphere.values.size(), 4u) << c.name;
      const double radius = sphere.values[3];
      const Eigen::Vector3d centre(sphere.values[0], sphere.values[1], sphere.values[2]);
      std::printf(
          "%s %s: sphere of %zu inliers (of %zu near), radius %.4f m (true %.2f, %+.2f %%), "
          "centre off by %.1f mm\n",
          perception::MatcherParams::modeName(mode), c.name, inliers.indices.size(), near->size(),
          radius, ball.radius_m, 100 * (radius / ball.radius_m - 1),
          1000 * (centre - ball.trajectory.centre_m).norm());
      EXPECT_NEAR(radius, ball.radius_m, 0.05 * ball.radius_m) << c.name;
      EXPECT_GT(inliers.indices.size(), near->size() / 2) << c.name;
    }
  }
}
