// The renderer against the rig model's projection: what is drawn is where the model says.
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>

#include "sim/render/renderer.hpp"
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

namespace {

// The default scenario with more to get wrong across bands: a textured box in front of the red
// ball's path, a large sphere cut by the image's left edge, a chessboard (its rays read the rows
// around each pixel) and the default objects behind them.
Scene crowdedScene() {
  cv::FileStorage fs(PTZ_SOURCE_DIR "/config/sim_default.yaml", cv::FileStorage::READ);
  Scene scene = Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"], "sim_default");
  SceneObject box;
  box.name = "front_box";
  box.shape = SceneObject::Shape::kBox;
  box.half_extents_m = {0.25, 0.2, 0.1};
  box.yaw_rad = 0.4;
  box.yaw_rate_rad_s = 0.3;
  box.textured = true;
  box.color_bgr = {40, 200, 200};
  box.trajectory.centre_m = {0.3, 0.1, 2.0};
  scene.objects.push_back(box);
  SceneObject edge;
  edge.name = "edge_ball";
  edge.radius_m = 0.5;
  edge.textured = true;
  edge.color_bgr = {200, 40, 200};
  edge.trajectory.centre_m = {-2.2, -0.2, 3.5};
  scene.objects.push_back(edge);
  scene.chessboard.present = true;
  scene.chessboard.square_m = 0.03;
  scene.chessboard.centre_head_m = {0.9, -0.5, 3.0};
  scene.chessboard.rotation_head_board =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, 1, 0).normalized()).toRotationMatrix();
  return scene;
}

// Restores OpenCV's thread count however the test ends.
struct ThreadCountGuard {
  int threads = cv::getNumThreads();
  ~ThreadCountGuard() { cv::setNumThreads(threads); }
};

}  // namespace

// Lockstep runs depend on it: rendering on all threads, in any number of bands, writes the same
// bytes as one thread in one band, and the same visible fractions to the last bit; and so does
// a background kept from the frame before.
TEST(Renderer, BandsAndThreadsGiveByteIdenticalImagesAndFractions) {
  const ThreadCountGuard guard;
  const Scene scene = crowdedScene();
  struct Shot {
    double t_s;
    PtzPose pose;
  };
  // Home (the chessboard and the cut sphere in view), panned and zoomed (objects cut by the
  // borders), the same pose three times (its background drawn, kept, reused) and tilted down.
  const std::vector<Shot> shots = {{0.0, {0, 0, 1}},           {4.0, {0.25, 0.08, 1.8}},
                                   {4.5, {0.25, 0.08, 1.8}},   {5.0, {0.25, 0.08, 1.8}},
                                   {9.0, {-0.35, -0.05, 3.0}}, {12.0, {0.1, 0.3, 1.3}}};
  bool partly_hidden = false;
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1920, 1080)}) {
    const StereoRig rig = StereoRig::makeDefault().atSize(size.width, size.height);
    // The reference renders both cameras in turn, so it draws every background afresh.
    Renderer reference(scene);
    reference.setBands(1);
    std::vector<Renderer> threaded(2, Renderer(scene)), odd_bands(2, Renderer(scene));
    for (Renderer& r : odd_bands) r.setBands(7);
    for (const Shot& shot : shots) {
      for (Side side : {Side::kLeft, Side::kRight}) {
        const ptz::CameraView view = rig.view(side, shot.pose);
        cv::Mat expected, image;
        std::vector<double> expected_fraction, fraction;
        cv::setNumThreads(1);
        reference.render(view, shot.t_s, &expected, &expected_fraction);
        cv::setNumThreads(guard.threads);
        const std::string what = std::to_string(size.width) + "x" + std::to_string(size.height) +
                                 " " + ptz::sideName(side) + " t " + std::to_string(shot.t_s);
        const auto camera = static_cast<size_t>(side);
        for (Renderer* renderer : {&threaded[camera], &odd_bands[camera]}) {
          renderer->render(view, shot.t_s, &image, &fraction);
          ASSERT_EQ(cv::norm(expected, image, cv::NORM_INF), 0) << what;
          ASSERT_EQ(fraction.size(), expected_fraction.size());
          for (size_t i = 0; i < fraction.size(); ++i) {
            EXPECT_EQ(fraction[i], expected_fraction[i]) << what << " object " << i;
            partly_hidden = partly_hidden || (fraction[i] > 0 && fraction[i] < 1);
          }
        }
      }
    }
  }
  EXPECT_TRUE(partly_hidden) << "no object was partly hidden: the scene tests too little";
}

// The whole capture (both cameras and their noise) is the same on one thread and on all.
TEST(Simulator, CapturesAreByteIdenticalOnOneThreadAndOnAll) {
  const ThreadCountGuard guard;
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1920, 1080)}) {
    const StereoRig rig = StereoRig::makeDefault().atSize(size.width, size.height);
    ptz::sim::Simulator one(rig, crowdedScene(), ptz::defaultPlantParams(), 2.0, 3);
    ptz::sim::Simulator all(rig, crowdedScene(), ptz::defaultPlantParams(), 2.0, 3);
    for (int i = 0; i < 3; ++i) {
      for (ptz::sim::Simulator* sim : {&one, &all}) {
        int clamped = 0, rejected = 0;
        sim->command(i * 0.5, {0.2 * i, 0.05, 1.0 + i}, {0.2 * i - 0.02, 0.05, 1.0 + i}, &clamped,
                     &rejected);
        sim->advanceTo(i * 0.5 + 0.3);
      }
      cv::setNumThreads(1);
      const ptz::sim::SimFrame a = one.capture();
      cv::setNumThreads(guard.threads);
      const ptz::sim::SimFrame b = all.capture();
      EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0) << size << " frame " << i;
      EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0) << size << " frame " << i;
      EXPECT_EQ(a.visible_fraction, b.visible_fraction) << size << " frame " << i;
    }
  }
}
