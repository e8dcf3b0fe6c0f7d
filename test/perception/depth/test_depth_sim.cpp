// ptz-depth's library on rendered frames of the true rig, against the scene's exact geometry:
// depth of backdrop and floor points, and the radius of a sphere fitted to its cloud.
#include <gtest/gtest.h>
#include <pcl/ModelCoefficients.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <cmath>
#include <limits>

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
std::vector<cv::Point3f> cloudOf(const StereoRig& rig, const sim::Scene& scene, const Case& c,
                                 const perception::DepthParams& depth_params,
                                 const perception::CloudParams& cloud_params) {
  const Pair pair = renderPair(rig, scene, c.left, c.right);
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

}  // namespace

TEST(DepthSim, BackdropAndFloorDepthWithinOnePercentRms) {
  const StereoRig rig = StereoRig::makeDefault();
  sim::Scene scene;
  scene.backdrop_distance_m = 4.8;
  scene.floor_height_m = 1.0;  // seen from about 2 m on
  using Mode = perception::MatcherParams::Mode;
  for (Mode mode : {Mode::kBm, Mode::kSgbm}) {
    for (const Case& c : kCases) {
      perception::DepthParams dp;
      dp.matcher.mode = mode;
      const std::vector<cv::Point3f> points = cloudOf(rig, scene, c, dp, {});
      const Eigen::Vector3d origin = rig.view(Side::kLeft, c.left).position_head_m;
      double sum_sq = 0;
      int n = 0;
      for (const auto& p : points) {
        const Eigen::Vector3d q(p.x, p.y, p.z);
        const double truth = trueRange(scene, origin, q);
        if (truth < 2.0 || truth > 5.0) continue;
        const double rel = ((q - origin).norm() - truth) / truth;
        sum_sq += rel * rel;
        ++n;
      }
      const double rms = std::sqrt(sum_sq / n);
      std::printf("%s %s: %zu cloud points, %d at 2-5 m, depth error %.3f %% RMS\n",
                  perception::MatcherParams::modeName(mode), c.name, points.size(), n, 100 * rms);
      EXPECT_GT(n, 1000) << c.name;
      EXPECT_LT(rms, 0.01) << c.name;
    }
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
      const std::vector<cv::Point3f> points = cloudOf(rig, scene, c, dp, cp);
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
