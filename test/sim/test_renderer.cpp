// The renderer against the rig model's projection: what is drawn is where the model says.
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>

#include "sim/renderer.hpp"
#include "sim/simulator.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
using ptz::sim::Renderer;
using ptz::sim::Scene;
using ptz::sim::SceneObject;

namespace {

Scene ballScene(const Eigen::Vector3d& centre, double radius) {
  Scene scene;
  SceneObject ball;
  ball.name = "ball";
  ball.class_name = "red_ball";
  ball.radius_m = radius;
  ball.color_bgr = {0, 0, 255};
  ball.trajectory.centre_m = centre;
  scene.objects.push_back(ball);
  return scene;
}

// Centroid of the pure-red pixels (the textures are grey-brown, never this red).
cv::Point2d redCentroid(const cv::Mat& bgr, double* area) {
  cv::Mat mask;
  cv::inRange(bgr, cv::Scalar(0, 0, 100), cv::Scalar(40, 40, 255), mask);
  const cv::Moments m = cv::moments(mask, true);
  *area = m.m00;
  return {m.m10 / m.m00, m.m01 / m.m00};
}

struct Case {
  Eigen::Vector3d centre;
  PtzPose pose;
};

}  // namespace

TEST(Renderer, SphereCentroidMatchesItsProjectionInBothCamerasWithDistortion) {
  const StereoRig rig = StereoRig::makeDefault();
  ASSERT_NE(rig.left.intrinsicsAt(1).distortion[0], 0.0);  // distortion is on
  const std::vector<Case> cases = {
      {{0.0, 0.0, 3.0}, {0, 0, 1}},
      {{1.2, -0.5, 3.0}, {0, 0, 1}},  // far off-axis: strong distortion
      {{-1.0, 0.6, 2.5}, {0, 0, 1}},
      {{0.9, -0.3, 2.5}, {0.3, 0.1, 1}},  // panned and tilted towards it
      {{0.5, 0.0, 4.0}, {0.1, 0.0, 3}},   // zoomed
      {{-0.3, 0.2, 1.5}, {-0.2, -0.1, 1.5}},
  };
  for (const auto& c : cases) {
    const double radius = 0.04;
    const Scene scene = ballScene(c.centre, radius);
    Renderer renderer(scene);
    for (Side side : {Side::kLeft, Side::kRight}) {
      const ptz::CameraView view = rig.view(side, c.pose);
      cv::Mat img;
      renderer.render(view, 0.0, &img);
      double area = 0;
      const cv::Point2d centroid = redCentroid(img, &area);
      const Eigen::Vector2d expected = view.project(c.centre);
      ASSERT_GT(area, 20) << "ball not visible";
      // The image of a sphere is centred on the projection of its centre up to a perspective
      // bias of about f * tan(angle) * (r / z)^2: well below 0.5 px at these distances.
      EXPECT_NEAR(centroid.x, expected.x(), 0.5)
          << ptz::sideName(side) << " " << c.centre.transpose();
      EXPECT_NEAR(centroid.y, expected.y(), 0.5)
          << ptz::sideName(side) << " " << c.centre.transpose();
      // Its area is that of the projected disc (f r / z)^2 pi, to a few percent.
      const double z = view.toCamera(c.centre).z();
      const double f = view.intrinsics.fx;
      EXPECT_NEAR(area, M_PI * std::pow(f * radius / z, 2),
                  0.1 * M_PI * std::pow(f * radius / z, 2));
    }
  }
}

TEST(Renderer, ChessboardCornersAreWhereTheRigProjectsThem) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene;
  scene.chessboard.present = true;
  scene.chessboard.inner_cols = 9;
  scene.chessboard.inner_rows = 6;
  scene.chessboard.square_m = 0.06;
  scene.chessboard.centre_head_m = {0.1, 0.05, 1.6};
  scene.chessboard.rotation_head_board =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  Renderer renderer(scene);
  for (Side side : {Side::kLeft, Side::kRight}) {
    const ptz::CameraView view = rig.view(side, {});
    cv::Mat img, gray;
    renderer.render(view, 0.0, &img);
    cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
    std::vector<cv::Point2f> corners;
    ASSERT_TRUE(cv::findChessboardCorners(gray, cv::Size(9, 6), corners));
    cv::cornerSubPix(gray, corners, cv::Size(5, 5), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 50, 1e-3));
    const auto truth = scene.chessboard.innerCorners();
    // OpenCV may report the grid from either end: compare with the nearer ordering.
    double err_fwd = 0, err_rev = 0;
    for (size_t i = 0; i < truth.size(); ++i) {
      const Eigen::Vector2d a = view.project(truth[i]);
      const Eigen::Vector2d b = view.project(truth[truth.size() - 1 - i]);
      err_fwd = std::max(err_fwd, std::hypot(corners[i].x - a.x(), corners[i].y - a.y()));
      err_rev = std::max(err_rev, std::hypot(corners[i].x - b.x(), corners[i].y - b.y()));
    }
    EXPECT_LT(std::min(err_fwd, err_rev), 0.3) << ptz::sideName(side);
  }
}

TEST(Renderer, BackgroundIsTexturedForStereo) {
  const StereoRig rig = StereoRig::makeDefault();
  Scene scene;
  Renderer renderer(scene);
  cv::Mat img, gray, lap;
  renderer.render(rig.view(Side::kLeft, {}), 0.0, &img);
  cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
  // Texture in every 40x40 block: block matching has something to match everywhere.
  for (int y = 0; y + 40 <= gray.rows; y += 40) {
    for (int x = 0; x + 40 <= gray.cols; x += 40) {
      cv::Scalar mean, stddev;
      cv::meanStdDev(gray(cv::Rect(x, y, 40, 40)), mean, stddev);
      EXPECT_GT(stddev[0], 3.0) << "flat block at " << x << "," << y;
    }
  }
}

TEST(Renderer, NoiseHasTheConfiguredSigmaAndIsRepeatable) {
  ptz::sim::NoiseBank bank(640, 480, 3.0, 5);
  cv::Mat a(480, 640, CV_8UC3, cv::Scalar(128, 128, 128)), b = a.clone(), c = a.clone();
  bank.apply(7, 0, &a);
  bank.apply(7, 0, &b);
  bank.apply(8, 0, &c);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_INF), 0);
  cv::Scalar mean, stddev;
  cv::meanStdDev(a.reshape(1), mean, stddev);
  EXPECT_NEAR(mean[0], 128, 0.1);
  EXPECT_NEAR(stddev[0], 3.0, 0.15);
}

TEST(Renderer, VisibleFractionsAreTheSharesNoNearerObjectHides) {
  // The ball straight ahead of the left camera, 3 m away; a box 2 m away whose left edge lies on
  // the ray to the ball's centre hides its right half (that edge projects to a straight line
  // through the principal point, distortion or not); a second box hides it all.
  const StereoRig rig = StereoRig::makeDefault();
  const ptz::CameraView view = rig.view(Side::kLeft, {});
  const Eigen::Vector3d c = view.position_head_m;
  Scene scene = ballScene(c + Eigen::Vector3d(0, 0, 3), 0.1);
  SceneObject box;
  box.name = "box";
  box.shape = SceneObject::Shape::kBox;
  box.half_extents_m = {0.5, 0.5, 0.05};
  box.color_bgr = {0, 200, 0};
  box.trajectory.centre_m = c + Eigen::Vector3d(0.5, 0, 2);
  scene.objects.push_back(box);
  std::vector<double> fraction;
  cv::Mat img;
  {
    Renderer renderer(scene);
    renderer.render(view, 0.0, &img, &fraction);
    ASSERT_EQ(fraction.size(), 2u);
    EXPECT_NEAR(fraction[0], 0.5, 0.02);
    EXPECT_DOUBLE_EQ(fraction[1], 1.0);  // nothing is in front of the box
  }
  scene.objects[1].trajectory.centre_m = c + Eigen::Vector3d(0, 0, 2);
  {
    Renderer renderer(scene);
    renderer.render(view, 0.0, &img, &fraction);
    EXPECT_DOUBLE_EQ(fraction[0], 0.0);
  }
  scene.objects[1].trajectory.centre_m = c + Eigen::Vector3d(0, 0, 4);  // behind the ball now
  {
    Renderer renderer(scene);
    renderer.render(view, 0.0, &img, &fraction);
    EXPECT_DOUBLE_EQ(fraction[0], 1.0);
    EXPECT_LT(fraction[1], 1.0);
  }
  // Out of the image: none of its pixels, fraction 0.
  scene.objects[0].trajectory.centre_m = c + Eigen::Vector3d(0, 0, -3);
  Renderer renderer(scene);
  renderer.render(view, 0.0, &img, &fraction);
  EXPECT_DOUBLE_EQ(fraction[0], 0.0);
}
