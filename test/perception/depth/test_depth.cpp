// ptz-depth's library against known answers: rectification against the rig model's projection,
// the horopter, and the cloud's layout and filters.
#include <gtest/gtest.h>
#include <unistd.h>
#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "perception/depth/cloud.hpp"
#include "perception/depth/depth.hpp"
#include "support/data_dir.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace perception = ptz::perception;

namespace {

cv::Mat cameraMatrix(const ptz::Intrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

// Rectified pixel of a head-frame point seen by `view` (distorted pixel, then undistorted and
// rectified by OpenCV with the rectification's R and P).
cv::Point2d rectifiedPixel(const ptz::CameraView& view, const cv::Mat& R, const cv::Mat& P,
                           const Eigen::Vector3d& p_head) {
  const Eigen::Vector2d px = view.project(p_head);
  std::vector<cv::Point2d> in{{px.x(), px.y()}}, out;
  cv::undistortPoints(in, out, cameraMatrix(view.intrinsics),
                      cv::Mat(view.intrinsics.distortion, true), R, P);
  return out[0];
}

bool inImage(const ptz::CameraView& v, const Eigen::Vector3d& p) {
  const Eigen::Vector2d px = v.project(p);
  return px.x() > 20 && px.y() > 20 && px.x() < v.width - 20 && px.y() < v.height - 20;
}

}  // namespace

TEST(Rectifier, RowsAlignAndDisparityAndReprojectionMatchTheRigModel) {
  const StereoRig rig = StereoRig::makeDefault();
  const std::vector<std::pair<PtzPose, PtzPose>> poses = {
      {{0, 0, 1}, {0, 0, 1}},
      {{0.15, 0.05, 1}, {0.10, 0.05, 1}},        // panned, tilted, verged
      {{0.10, 0.0, 1}, {-0.10, 0.0, 1}},         // strongly verged: negative disparities
      {{0.05, -0.03, 2.5}, {0.04, -0.03, 2.4}},  // zoomed, zooms differ
  };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-0.8, 0.8), uz(1.5, 8.0);
  for (const auto& [lp, rp] : poses) {
    perception::Rectifier rectifier(rig);
    std::string why;
    ASSERT_TRUE(rectifier.update(lp, rp, &why)) << why;
    const perception::Rectification& r = rectifier.current();
    const ptz::CameraView lv = rig.view(Side::kLeft, lp), rv = rig.view(Side::kRight, rp);
    Eigen::Matrix4d head_rect = Eigen::Matrix4d::Identity();
    head_rect.topLeftCorner<3, 3>() = r.rotation_head_rect;
    head_rect.topRightCorner<3, 1>() = r.position_head_m;
    cv::Mat H(4, 4, CV_64F);
    for (int i = 0; i < 16; ++i) H.at<double>(i / 4, i % 4) = head_rect(i / 4, i % 4);
    const cv::Mat M = H * r.Q;
    int checked = 0;
    for (int i = 0; i < 400; ++i) {
      const Eigen::Vector3d p(ux(rng), uy(rng), uz(rng));
      if (!inImage(lv, p) || !inImage(rv, p)) continue;
      const cv::Point2d l = rectifiedPixel(lv, r.R1, r.P1, p);
      const cv::Point2d rr = rectifiedPixel(rv, r.R2, r.P2, p);
      EXPECT_NEAR(l.y, rr.y, 0.01) << "rows not aligned";
      EXPECT_NEAR(l.x - rr.x, r.disparityOf(p), 0.01);
      std::vector<cv::Point3d> xyd{{l.x, l.y, l.x - rr.x}}, back;
      cv::perspectiveTransform(xyd, back, M);
      EXPECT_NEAR((Eigen::Vector3d(back[0].x, back[0].y, back[0].z) - p).norm(), 0, 1e-6 * p.z());
      ++checked;
    }
    EXPECT_GT(checked, 30);
  }
  // Cameras verging at about 1.5 m: a point at 5 m has a negative disparity.
  perception::Rectifier verged(rig);
  std::string why;
  ASSERT_TRUE(verged.update({0.10, 0, 1}, {-0.10, 0, 1}, &why));
  EXPECT_LT(verged.current().disparityOf({0, 0, 5}), 0);
  EXPECT_GT(verged.current().disparityOf({0, 0, 1}), 0);
}

TEST(Rectifier, RebuildsOnlyWhenThePoseChangesAndRefusesUnknownGeometry) {
  perception::Rectifier rectifier(StereoRig::makeDefault());
  std::string why;
  ASSERT_TRUE(rectifier.update({0, 0, 1}, {0, 0, 1}, &why));
  ASSERT_TRUE(rectifier.update({0, 0, 1}, {0, 0, 1}, &why));
  EXPECT_EQ(rectifier.rebuilds(), 1);
  ASSERT_TRUE(rectifier.update({0.01, 0, 1}, {0, 0, 1}, &why));
  EXPECT_EQ(rectifier.rebuilds(), 2);
  EXPECT_FALSE(rectifier.update({0, 0, 1}, {0, 0, 10.5}, &why));  // table ends at 10
  EXPECT_NE(why.find("right camera"), std::string::npos) << why;
  EXPECT_NE(why.find("zoom table"), std::string::npos) << why;
  EXPECT_FALSE(rectifier.update({NAN, 0, 1}, {0, 0, 1}, &why));
  EXPECT_FALSE(rectifier.update({0, 0, 0.5}, {0, 0, 1}, &why));
  EXPECT_EQ(rectifier.rebuilds(), 2);
}

TEST(Horopter, CentredOnTheTargetElseEndsAtTheFarDepth) {
  perception::Rectifier rectifier(StereoRig::makeDefault());
  std::string why;
  ASSERT_TRUE(rectifier.update({0.1, 0, 3}, {0.08, 0, 3}, &why));
  const perception::Rectification& r = rectifier.current();
  perception::HoropterParams p;
  const Eigen::Vector3d target(0.4, 0.1, 3.0);
  const double d = r.disparityOf(target);
  const int min_d = perception::chooseMinDisparity(r, p, 64, target);
  EXPECT_LE(min_d + 31, d);
  EXPECT_GE(min_d + 33, d);
  const int far = perception::chooseMinDisparity(r, p, 64, std::nullopt);
  EXPECT_LE(far, r.disparityAtDepth(p.far_depth_m));
  EXPECT_GT(far + 1, r.disparityAtDepth(p.far_depth_m));
  // Depth and disparity are each other's inverse (verged: the disparity may be negative).
  for (double depth_m : {0.5, 3.0, 40.0}) {
    EXPECT_NEAR(r.depthAtDisparity(r.disparityAtDepth(depth_m)), depth_m, 1e-9 * depth_m);
  }
  p.follow_target = false;
  EXPECT_EQ(perception::chooseMinDisparity(r, p, 64, target), far);
  p.far_depth_m = 0;
  p.min_disparity_px = -7;
  EXPECT_EQ(perception::chooseMinDisparity(r, p, 64, target), -7);
}

TEST(Cloud, PclLayoutVoxelGridAndOutlierRemoval) {
  std::vector<cv::Point3f> points;
  std::vector<cv::Vec3b> colours;
  // A 1 m square at z = 3 m sampled every 5 mm, and one point far off it.
  for (int i = 0; i < 200; ++i) {
    for (int j = 0; j < 200; ++j) {
      points.emplace_back(-0.5f + i * 0.005f, -0.5f + j * 0.005f, 3.0f);
      colours.emplace_back(10, 20, 30);
    }
  }
  points.emplace_back(0.0f, 0.0f, 4.0f);
  colours.emplace_back(10, 20, 30);
  perception::CloudParams p;
  p.voxel_size_m = 0.02;
  p.sor_mean_k = 8;  // PCL's statistical outlier removal (off by default: ptz-depth's grid filter)
  const ptzstereo::point_cloud_t c = perception::makeCloud(points, colours, p);
  EXPECT_EQ(c.frame_id, "head");
  EXPECT_EQ(c.height, 1);
  EXPECT_EQ(c.point_step, 32);  // pcl::PointXYZRGB
  EXPECT_EQ(c.data_size, c.width * c.point_step);
  std::map<std::string, int> offsets;
  for (const auto& f : c.fields) {
    offsets[f.name] = f.offset;
    EXPECT_EQ(f.datatype, ptzstereo::point_field_t::FLOAT32) << f.name;
  }
  EXPECT_EQ(offsets, (std::map<std::string, int>{{"x", 0}, {"y", 4}, {"z", 8}, {"rgb", 16}}));
  // 2 cm voxels on a 1 m square: 50 x 50 (a few more where the grid straddles a boundary).
  EXPECT_NEAR(c.width, 2500, 150);
  std::vector<cv::Point3f> back;
  ASSERT_TRUE(perception::cloudPoints(c, &back));
  ASSERT_EQ(back.size(), static_cast<size_t>(c.width));
  for (const auto& q : back) EXPECT_NEAR(q.z, 3.0f, 1e-4) << "the outlier is removed";
  // rgb packs r, g, b as PCL does (b in the lowest byte).
  uint32_t rgb = 0;
  std::memcpy(&rgb, c.data.data() + 16, 4);
  EXPECT_EQ(rgb & 0xffffffu, (30u << 16) | (20u << 8) | 10u);
}

TEST(Cloud, GridOutliersAreDroppedWhateverTheDepthOrTheAngle) {
  // A 40 x 20 sampling grid of a camera (f = 500 px, every 4th pixel, so 1/125 rad a step): a
  // wall at 2 m across 32 columns (up to 24 degrees off the axis) and one at 8 m in 7 (its
  // neighbours 4 times as far apart), a gap column between them; a flying point at 5 m in
  // front of the near wall, and a point with no neighbours. At the default 1 sigma only those
  // two go: spread is measured against depth, not range (which would favour the centre) or
  // nothing (which would drop the far wall).
  const int cols = 40, rows = 20;
  const float step = 1.0f / 125;
  std::vector<int> cell(static_cast<size_t>(cols) * rows, -1);
  std::vector<cv::Point3f> points;
  std::vector<cv::Vec3b> colours;
  std::vector<float> depths;
  auto put = [&](int gx, int gy, float z) {
    cell[static_cast<size_t>(gy) * cols + gx] = static_cast<int>(points.size());
    points.emplace_back((gx - 16) * step * z, (gy - 10) * step * z, z);
    colours.emplace_back(static_cast<uchar>(gx), static_cast<uchar>(gy), 0);
    depths.push_back(z);
  };
  auto walls = [&](bool with_outliers) {
    cell.assign(cell.size(), -1);
    points.clear();
    colours.clear();
    depths.clear();
    for (int gy = 0; gy < 18; ++gy) {
      for (int gx = 0; gx < cols; ++gx) {
        if (gx == 32) continue;  // the gap
        const bool flying = with_outliers && gx == 20 && gy == 8;
        put(gx, gy, gx < 32 ? (flying ? 5.0f : 2.0f) : 8.0f);
      }
    }
    if (with_outliers) put(36, 19, 8.0f);  // alone: row 18 is empty
  };
  const perception::DepthParams defaults;
  // The walls alone: nothing to drop (the flying point would hide the rest in its variance).
  walls(false);
  const size_t wall_points = points.size();
  EXPECT_EQ(perception::removeGridOutliers(cell, cols, depths, defaults.outlier_stddev_mult,
                                           &points, &colours),
            0u);
  EXPECT_EQ(points.size(), wall_points);
  walls(true);
  const size_t before = points.size();
  EXPECT_EQ(perception::removeGridOutliers(cell, cols, depths, defaults.outlier_stddev_mult,
                                           &points, &colours),
            2u);
  ASSERT_EQ(points.size(), before - 2);
  ASSERT_EQ(colours.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_NE(points[i].z, 5.0f) << "the flying point";
    EXPECT_FALSE(colours[i][0] == 36 && colours[i][1] == 19) << "the lonely point";
    // Its colour is still its own: x and y say where on the grid it came from.
    EXPECT_NEAR(points[i].x / (step * points[i].z) + 16, colours[i][0], 1e-3);
    EXPECT_NEAR(points[i].y / (step * points[i].z) + 10, colours[i][1], 1e-3);
  }
  // Too few points for statistics: all kept.
  std::vector<int> small_cell = {0, 1, -1, 2};
  std::vector<cv::Point3f> small = {{0, 0, 2}, {0.1f, 0, 2}, {0, 0, 9}};
  std::vector<cv::Vec3b> small_colours(3);
  EXPECT_EQ(perception::removeGridOutliers(small_cell, 2, {2, 2, 9}, 1.0, &small, &small_colours),
            0u);
  EXPECT_EQ(small.size(), 3u);
}

TEST(Cloud, PcdWrittenOrAClearError) {
  const ptzstereo::point_cloud_t c =
      perception::makeCloud({{0, 0, 1}, {0, 0.1f, 1}}, {{1, 2, 3}, {4, 5, 6}}, {0.0, 0, 2.0});
  const std::string path = ::testing::TempDir() + "ptz_depth_test.pcd";
  std::string error;
  ASSERT_TRUE(perception::writePcd(c, path, &error)) << error;
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.rfind("# .PCD", 0), 0u);
  EXPECT_NE(text.find("POINTS 2"), std::string::npos);
  EXPECT_NE(text.find("FIELDS x y z"), std::string::npos);  // PCL's padding shows as "_"
  EXPECT_NE(text.find(" rgb"), std::string::npos);
  // pcl_viewer's camera beside it (test_pcd_viewer.cpp: what it shows).
  const std::string cam = ::testing::TempDir() + "ptz_depth_test.cam";
  std::ifstream cam_in(cam);
  std::string cam_line;
  ASSERT_TRUE(std::getline(cam_in, cam_line)) << cam;
  EXPECT_EQ(std::count(cam_line.begin(), cam_line.end(), '/'), 6) << cam_line;
  std::remove(cam.c_str());
  std::remove(path.c_str());
  EXPECT_FALSE(perception::writePcd(c, "/nonexistent-dir/cloud.pcd", &error));
  EXPECT_NE(error.find("/nonexistent-dir/cloud.pcd"), std::string::npos) << error;
}

// The preview that crosses a LAN: every k-th point, within its byte bound, the points unchanged.
TEST(Cloud, APreviewKeepsEveryKthPointWithinItsBytes) {
  std::vector<cv::Point3f> points;
  std::vector<cv::Vec3b> colours;
  for (int i = 0; i < 1000; ++i) {
    points.emplace_back(0.01f * i, 0.0f, 2.0f);
    colours.emplace_back(1, 2, 3);
  }
  perception::CloudParams none;
  none.voxel_size_m = 0;  // all 1000 points, in order
  const ptzstereo::point_cloud_t c = perception::makeCloud(points, colours, none);
  ASSERT_EQ(c.width, 1000);
  // 32 bytes a point: 3200 bytes hold 100, so every 10th.
  const ptzstereo::point_cloud_t p = perception::decimateCloud(c, 3200);
  EXPECT_EQ(p.width, 100);
  EXPECT_EQ(p.height, 1);
  EXPECT_EQ(p.data_size, 3200);
  EXPECT_EQ(p.row_step, 3200);
  std::vector<cv::Point3f> back;
  ASSERT_TRUE(perception::cloudPoints(p, &back));
  ASSERT_EQ(back.size(), 100u);
  EXPECT_FLOAT_EQ(back[1].x, 0.10f);
  EXPECT_FLOAT_EQ(back[99].x, 9.90f);
  // A bound that does not divide: 3199 bytes hold 99, so every 11th (91 points).
  EXPECT_EQ(perception::decimateCloud(c, 3199).width, 91);
  // Under its bound already: all of it.
  EXPECT_EQ(perception::decimateCloud(c, 1'000'000).width, 1000);
  // A layout whose sizes disagree gives nothing, never a read past the data.
  ptzstereo::point_cloud_t bad = c;
  bad.width = 2000;
  EXPECT_EQ(perception::decimateCloud(bad, 3200).width, 0);
  EXPECT_TRUE(perception::decimateCloud(bad, 3200).data.empty());
}
