// The rig model against hand-computed projections and poses, and its file format.
#include <gtest/gtest.h>
#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "common/config.hpp"
#include "common/rig.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;

namespace {

// A rig whose numbers are easy to follow by hand.
StereoRig simpleRig() {
  StereoRig rig;
  for (auto* cam : {&rig.left, &rig.right}) {
    ptz::Intrinsics k;
    k.fx = 800;
    k.fy = 780;
    k.cx = 320;
    k.cy = 240;
    k.distortion = {0, 0, 0, 0, 0};
    cam->zoom_table = {{1.0, k}};
    cam->optical_centre_from_pivot_m = Eigen::Vector3d::Zero();
  }
  rig.home.T = Eigen::Vector3d(-0.3, 0, 0);
  return rig;
}

std::string tempPath(const std::string& name) {
  return (std::string(::testing::TempDir()) + "/" + name);
}

void writeFile(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

}  // namespace

TEST(Rig, ProjectsWithBrownDistortionLikeTheFormula) {
  StereoRig rig = simpleRig();
  ptz::Intrinsics& k = rig.left.zoom_table[0].intrinsics;
  k.distortion = {-0.2, 0.05, 0.001, -0.002, 0.01};
  const ptz::CameraView view = rig.view(Side::kLeft, {});
  const Eigen::Vector3d p(0.4, -0.3, 2.0);
  // Hand-written Brown model: x = X/Z = 0.2, y = -0.15, r^2 = 0.0625.
  const double x = 0.2, y = -0.15, r2 = 0.0625;
  const double radial = 1 - 0.2 * r2 + 0.05 * r2 * r2 + 0.01 * r2 * r2 * r2;
  const double xd = x * radial + 2 * 0.001 * x * y + -0.002 * (r2 + 2 * x * x);
  const double yd = y * radial + 0.001 * (r2 + 2 * y * y) + 2 * -0.002 * x * y;
  // The left camera at home sits at -T/2 = (-0.15, 0, 0) in the head frame.
  const Eigen::Vector2d px = view.project(p + Eigen::Vector3d(-0.15, 0, 0));
  EXPECT_NEAR(px.x(), 800 * xd + 320, 0.01);
  EXPECT_NEAR(px.y(), 780 * yd + 240, 0.01);
  // And OpenCV agrees.
  std::vector<cv::Point3d> obj{{0.4, -0.3, 2.0}};
  std::vector<cv::Point2d> img;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                    cv::Matx33d(800, 0, 320, 0, 780, 240, 0, 0, 1),
                    std::vector<double>{-0.2, 0.05, 0.001, -0.002, 0.01}, img);
  EXPECT_NEAR(px.x(), img[0].x, 1e-6);
  EXPECT_NEAR(px.y(), img[0].y, 1e-6);
}

TEST(Rig, PointBehindTheCameraDoesNotProject) {
  const ptz::CameraView view = simpleRig().view(Side::kLeft, {});
  EXPECT_TRUE(std::isnan(view.project({0, 0, -1}).x()));
}

TEST(Rig, PanAndTiltTurnTheOpticalAxisAsDocumented) {
  StereoRig rig = simpleRig();
  // Pan +30 deg: the optical axis turns to +x (right); tilt +20 deg: to -y (up).
  const auto pan = rig.view(Side::kLeft, {M_PI / 6, 0, 1});
  const Eigen::Vector3d axis_pan = pan.rotation_head_camera * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(axis_pan.x(), 0.5, 1e-12);
  EXPECT_NEAR(axis_pan.z(), std::sqrt(3) / 2, 1e-12);
  const auto tilt = rig.view(Side::kLeft, {0, M_PI / 9, 1});
  const Eigen::Vector3d axis_tilt = tilt.rotation_head_camera * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(axis_tilt.y(), -std::sin(M_PI / 9), 1e-12);
  // A point straight ahead of the panned camera lands on the principal point.
  const Eigen::Vector2d px = pan.project(pan.position_head_m + 3.0 * axis_pan);
  EXPECT_NEAR(px.x(), 320, 1e-9);
  EXPECT_NEAR(px.y(), 240, 1e-9);
}

TEST(Rig, ExtrinsicsAfterPanMatchAHandComputedCase) {
  StereoRig rig = simpleRig();
  // Optical centres 40 mm in front of the pivots.
  rig.left.optical_centre_from_pivot_m = {0, 0, 0.04};
  rig.right.optical_centre_from_pivot_m = {0, 0, 0.04};
  const double a = 0.2;  // left pans 0.2 rad, right stays home
  const auto e = rig.extrinsics({a, 0, 1}, {0, 0, 1});
  // Left: pivot (-0.15, 0, -0.04), centre pivot + Ry(a)(0, 0, 0.04); right centre (0.15, 0, 0).
  const Eigen::Vector3d cl(-0.15 + 0.04 * std::sin(a), 0, -0.04 + 0.04 * std::cos(a));
  const Eigen::Vector3d cr(0.15, 0, 0);
  Eigen::Matrix3d Ry;
  Ry << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  EXPECT_LT((e.R - Ry).norm(), 1e-12);
  EXPECT_LT((e.T - (cl - cr)).norm(), 1e-12);
  // At home the extrinsics are the calibrated ones.
  const auto home = rig.extrinsics({}, {});
  EXPECT_LT((home.T - rig.home.T).norm(), 1e-12);
  EXPECT_LT((home.R - rig.home.R).norm(), 1e-12);
}

TEST(Rig, TriangulationWithCurrentExtrinsicsRecoversAPointAfterPanTiltZoom) {
  const StereoRig rig = StereoRig::makeDefault();
  const Eigen::Vector3d p(0.7, -0.2, 3.2);
  const PtzPose lp{0.22, 0.08, 2.5}, rp{0.15, 0.05, 2.5};
  const auto lv = rig.view(Side::kLeft, lp), rv = rig.view(Side::kRight, rp);
  const auto e = rig.extrinsics(lp, rp);
  std::vector<cv::Point2d> pl{{lv.project(p).x(), lv.project(p).y()}};
  std::vector<cv::Point2d> pr{{rv.project(p).x(), rv.project(p).y()}};
  auto undistort = [](const ptz::Intrinsics& k, std::vector<cv::Point2d>& pts) {
    cv::undistortPoints(
        pts, pts, cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1),
        std::vector<double>(k.distortion.begin(), k.distortion.end()), cv::noArray(), cv::noArray(),
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
  };
  undistort(lv.intrinsics, pl);
  undistort(rv.intrinsics, pr);
  cv::Matx34d P1 = cv::Matx34d::eye(), P2;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) P2(r, c) = e.R(r, c);
    P2(r, 3) = e.T(r);
  }
  cv::Mat X;
  cv::triangulatePoints(P1, P2, pl, pr, X);
  X.convertTo(X, CV_64F);
  const Eigen::Vector3d in_left(X.at<double>(0) / X.at<double>(3),
                                X.at<double>(1) / X.at<double>(3),
                                X.at<double>(2) / X.at<double>(3));
  const Eigen::Vector3d in_head = lv.rotation_head_camera * in_left + lv.position_head_m;
  EXPECT_LT((in_head - p).norm(), 1e-6);
}

TEST(Rig, ZoomTableInterpolatesLinearly) {
  const StereoRig rig = StereoRig::makeDefault();
  const auto k1 = rig.left.intrinsicsAt(1.0), k2 = rig.left.intrinsicsAt(2.0);
  const auto k15 = rig.left.intrinsicsAt(1.5);
  EXPECT_DOUBLE_EQ(k15.fx, (k1.fx + k2.fx) / 2);
  EXPECT_DOUBLE_EQ(k15.distortion[0], (k1.distortion[0] + k2.distortion[0]) / 2);
  EXPECT_DOUBLE_EQ(rig.left.intrinsicsAt(0.5).fx, k1.fx);  // clamped to the table
  EXPECT_DOUBLE_EQ(rig.left.intrinsicsAt(20).fx, rig.left.intrinsicsAt(10).fx);
}

// A point's pixel at 1080p is its VGA pixel scaled by 3 about pixel centres, less the 180 rows
// that 16:9 crops from 4:3 at the top (1440 rows scaled, 1080 kept).
TEST(Rig, AtAnotherSizeAPointLandsOnTheScaledPixel) {
  const StereoRig vga = StereoRig::makeDefault();
  const StereoRig hd = vga.atSize(1920, 1080);
  EXPECT_EQ(hd.left.width, 1920);
  EXPECT_EQ(hd.right.height, 1080);
  const PtzPose pose{0.1, -0.05, 3.0};
  for (Side side : {Side::kLeft, Side::kRight}) {
    for (const Eigen::Vector3d& p :
         {Eigen::Vector3d(0.2, -0.1, 4.0), Eigen::Vector3d(-1, 0.5, 6)}) {
      const Eigen::Vector2d a = vga.view(side, pose).project(p);
      const Eigen::Vector2d b = hd.view(side, pose).project(p);
      EXPECT_NEAR(b.x(), (a.x() + 0.5) * 3 - 0.5, 1e-9);
      EXPECT_NEAR(b.y(), (a.y() + 0.5) * 3 - 0.5 - 180, 1e-9);
    }
  }
  EXPECT_NEAR(hd.baselineM(), vga.baselineM(), 0);
}

TEST(RigFile, RoundTrip) {
  const StereoRig rig = StereoRig::makeDefault();
  const std::string path = tempPath("rig_roundtrip.yaml");
  rig.save(path);
  const StereoRig back = StereoRig::load(path);
  ASSERT_EQ(back.left.zoom_table.size(), rig.left.zoom_table.size());
  for (size_t i = 0; i < rig.left.zoom_table.size(); ++i) {
    EXPECT_DOUBLE_EQ(back.right.zoom_table[i].zoom, rig.right.zoom_table[i].zoom);
    EXPECT_DOUBLE_EQ(back.right.zoom_table[i].intrinsics.fx, rig.right.zoom_table[i].intrinsics.fx);
    EXPECT_DOUBLE_EQ(back.right.zoom_table[i].intrinsics.distortion[3],
                     rig.right.zoom_table[i].intrinsics.distortion[3]);
  }
  EXPECT_LT((back.home.R - rig.home.R).norm(), 1e-15);
  EXPECT_LT((back.home.T - rig.home.T).norm(), 1e-15);
  EXPECT_EQ(back.left.optical_centre_from_pivot_m, rig.left.optical_centre_from_pivot_m);
  EXPECT_EQ(back.left.width, 640);
}

namespace {
std::string loadError(const std::string& path) {
  try {
    StereoRig::load(path);
  } catch (const ptz::ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(RigFile, BadFilesNameTheFileAndTheField) {
  const std::string missing = tempPath("no_such_rig.yaml");
  std::remove(missing.c_str());
  std::string err = loadError(missing);
  EXPECT_NE(err.find(missing), std::string::npos) << err;
  EXPECT_NE(err.find("cannot open"), std::string::npos) << err;

  const std::string malformed = tempPath("malformed_rig.yaml");
  writeFile(malformed, "%YAML:1.0\n---\nimage_width: [1, 2\n  : : oops\n");
  err = loadError(malformed);
  EXPECT_NE(err.find(malformed), std::string::npos) << err;
  EXPECT_NE(err.find("malformed"), std::string::npos) << err;

  // A good file with one field taken out or broken at a time.
  const std::string good = tempPath("good_rig.yaml");
  StereoRig::makeDefault().save(good);
  std::ifstream in(good);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  struct Case {
    std::string from, to, field;
  };
  const std::vector<Case> cases = {
      {"image_width: 640", "image_wide: 640", "image_width"},
      {"zoom_table:", "zoom_tabel:", "zoom_table"},
      {"optical_centre_from_pivot_m", "optical_centre", "optical_centre_from_pivot_m"},
      {"\nT: !!opencv-matrix\n   rows: 3", "\nT: !!opencv-matrix\n   rows: 1", ", T: must be"},
      // Unknown fields at every level, and values out of range, named with their path and value.
      {"image_width: 640", "image_width: 640\nimage_heigth: 480", ", image_heigth: unknown field"},
      {"zoom_table:", "zoom_tabel: 1\n   zoom_table:", "left.zoom_tabel: unknown field"},
      {"zoom: 1.", "zoom: 1.\n         focus: 3", "left.zoom_table[0].focus: unknown field"},
      {"image_width: 640", "image_width: 0", "image_width: must be within 1 .. 16384, got '0'"},
      {"zoom: 1.", "zoom: -1.", "left.zoom_table[0].zoom: must be > 0, got '-1'"},
  };
  for (const auto& c : cases) {
    std::string broken = text;
    const auto pos = broken.find(c.from);
    ASSERT_NE(pos, std::string::npos) << c.from;
    broken.replace(pos, c.from.size(), c.to);
    const std::string path = tempPath("broken_rig.yaml");
    writeFile(path, broken);
    err = loadError(path);
    EXPECT_NE(err.find(path), std::string::npos) << err;
    EXPECT_NE(err.find(c.field), std::string::npos) << "expected '" << c.field << "' in: " << err;
  }
}
