// ptz-depth's library against known answers: rectification against the rig model's projection
// (also decimated), the remap against OpenCV's, the horopter, and the cloud's layout and filters
// (the voxel grid against PCL's).
#include <gtest/gtest.h>
#include <pcl/conversions.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#include <unistd.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <tuple>

#include "perception/depth/cloud.hpp"
#include "perception/depth/depth.hpp"
#include "perception/depth/remap.hpp"
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
  const std::vector<std::pair<PtzPose, PtzPose>> poses = {
      {{0, 0, 1}, {0, 0, 1}},
      {{0.15, 0.05, 1}, {0.10, 0.05, 1}},        // panned, tilted, verged
      {{0.10, 0.0, 1}, {-0.10, 0.0, 1}},         // strongly verged: negative disparities
      {{0.05, -0.03, 2.5}, {0.04, -0.03, 2.4}},  // zoomed, zooms differ
  };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-0.8, 0.8), uz(1.5, 8.0);
  // VGA, and 1080p decimated by 2: its P and Q are the decimated image's, its points metres.
  for (const auto& [rig, decimation] :
       {std::pair{StereoRig::makeDefault(), 1},
        std::pair{StereoRig::makeDefault().atSize(1920, 1080), 2}}) {
    for (const auto& [lp, rp] : poses) {
      perception::Rectifier rectifier(rig, decimation);
      std::string why;
      ASSERT_TRUE(rectifier.update(lp, rp, &why)) << why;
      const perception::Rectification& r = rectifier.current();
      EXPECT_EQ(r.size, cv::Size(rig.left.width / decimation, rig.left.height / decimation));
      const StereoRig matched = perception::decimatedRig(rig, decimation);
      const ptz::CameraView lv = matched.view(Side::kLeft, lp), rv = matched.view(Side::kRight, rp);
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
  }
  // Cameras verging at about 1.5 m: a point at 5 m has a negative disparity.
  perception::Rectifier verged(StereoRig::makeDefault());
  std::string why;
  ASSERT_TRUE(verged.update({0.10, 0, 1}, {-0.10, 0, 1}, &why));
  EXPECT_LT(verged.current().disparityOf({0, 0, 5}), 0);
  EXPECT_GT(verged.current().disparityOf({0, 0, 1}), 0);
}

// A camera decimated by f sees at ((x, y) + 0.5) / f - 0.5 what the full one sees at (x, y): the
// centres of the f x f blocks that cv::INTER_AREA averages.
TEST(Rectifier, DecimatedRigIsTheBlockAveragedImage) {
  EXPECT_EQ(perception::decimationFor(640, 1000), 1);
  EXPECT_EQ(perception::decimationFor(1000, 1000), 1);
  EXPECT_EQ(perception::decimationFor(1001, 1000), 2);
  EXPECT_EQ(perception::decimationFor(1920, 1000), 2);
  EXPECT_EQ(perception::decimationFor(3840, 1000), 4);
  EXPECT_EQ(perception::decimationFor(1920, 0), 1);
  const StereoRig rig = StereoRig::makeDefault().atSize(1920, 1080);
  for (int f : {2, 3}) {
    const StereoRig d = perception::decimatedRig(rig, f);
    EXPECT_EQ(d.left.width, 1920 / f);
    EXPECT_EQ(d.left.height, 1080 / f);
    const PtzPose pose{0.1, -0.05, 3.0};
    for (Side side : {Side::kLeft, Side::kRight}) {
      for (const Eigen::Vector3d& p :
           {Eigen::Vector3d(0.4, -0.2, 3.0), Eigen::Vector3d(-1.0, 0.5, 6.0)}) {
        const Eigen::Vector2d full = rig.view(side, pose).project(p);
        const Eigen::Vector2d small = d.view(side, pose).project(p);
        EXPECT_NEAR(small.x(), (full.x() + 0.5) / f - 0.5, 1e-9);
        EXPECT_NEAR(small.y(), (full.y() + 0.5) / f - 0.5, 1e-9);
      }
    }
  }
}

// The fast remap gives cv::remap's pixels exactly: rectification maps of several geometries and
// sizes, and maps that leave the image, turn (rows change within 8 pixels) and scale.
TEST(Remap, SameAsOpenCvsBitForBit) {
  std::printf("remap fast path (SSSE3) on this CPU: %s\n",
              perception::remapGreyHasSimd() ? "yes" : "no");
  std::mt19937 rng(11);
  auto check = [&rng](const cv::Mat& xy, const cv::Mat& frac, cv::Size src_size,
                      const std::string& what) {
    cv::Mat src(src_size, CV_8UC1);
    cv::randu(src, 0, 256);
    cv::Mat expected, fast;
    cv::remap(src, expected, xy, frac, cv::INTER_LINEAR);
    perception::remapGrey(src, xy, frac, &fast);
    ASSERT_EQ(fast.size(), expected.size()) << what;
    EXPECT_EQ(cv::countNonZero(fast != expected), 0) << what;
    // A source that is a view into a wider image (its own row step).
    cv::Mat wide(src_size.height, src_size.width + 13, CV_8UC1);
    src.copyTo(wide.colRange(5, 5 + src_size.width));
    perception::remapGrey(wide.colRange(5, 5 + src_size.width), xy, frac, &fast);
    EXPECT_EQ(cv::countNonZero(fast != expected), 0) << what << " (roi)";
  };
  for (const auto& [w, h, f] : {std::tuple{640, 480, 1}, std::tuple{1920, 1080, 2}}) {
    const StereoRig rig = StereoRig::makeDefault().atSize(w, h);
    for (const auto& [lp, rp] :
         std::vector<std::pair<PtzPose, PtzPose>>{{{0, 0, 1}, {0, 0, 1}},
                                                  {{0.10, 0.0, 1}, {-0.10, 0.0, 1}},
                                                  {{0.05, -0.03, 2.5}, {0.04, -0.03, 2.4}}}) {
      perception::Rectifier rectifier(rig, f);
      std::string why;
      ASSERT_TRUE(rectifier.update(lp, rp, &why)) << why;
      const perception::Rectification& r = rectifier.current();
      check(r.map_left[0], r.map_left[1], r.size, "left " + std::to_string(w));
      check(r.map_right[0], r.map_right[1], r.size, "right " + std::to_string(w));
    }
  }
  // Rotated by 30 degrees, scaled by 1.3 and shifted partly outside a 100 x 80 image.
  cv::Mat affine(97, 131, CV_32FC2);
  for (int y = 0; y < affine.rows; ++y) {
    for (int x = 0; x < affine.cols; ++x) {
      const double c = std::cos(0.52) * 1.3, s = std::sin(0.52) * 1.3;
      affine.at<cv::Vec2f>(y, x) =
          cv::Vec2f(static_cast<float>(c * x - s * y + 20), static_cast<float>(s * x + c * y - 30));
    }
  }
  cv::Mat xy, frac;
  cv::convertMaps(affine, cv::noArray(), xy, frac, CV_16SC2);
  check(xy, frac, {100, 80}, "rotated");
  // Anywhere in and around the image, any fraction.
  cv::Mat random_xy(60, 203, CV_16SC2), random_frac(60, 203, CV_16UC1);
  cv::randu(random_xy, -20, 140);
  cv::randu(random_frac, 0, 1024);
  check(random_xy, random_frac, {120, 90}, "random");
  // Nearly the identity with the rows of the image's last pixels: the vector path's edges.
  cv::Mat edge(90, 120, CV_32FC2);
  for (int y = 0; y < edge.rows; ++y) {
    for (int x = 0; x < edge.cols; ++x) {
      edge.at<cv::Vec2f>(y, x) = cv::Vec2f(x * 1.01f - 0.6f, y + 0.003f * x - 0.2f);
    }
  }
  cv::convertMaps(edge, cv::noArray(), xy, frac, CV_16SC2);
  check(xy, frac, {120, 90}, "edges");
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

TEST(DepthEstimator, RefusesImagesNotOfTheRigsSizeAndDecimatesWideOnes) {
  perception::DepthEstimator vga(StereoRig::makeDefault(), {});
  EXPECT_EQ(vga.decimation(), 1);
  perception::DepthFrame frame;
  std::string why;
  const cv::Mat small(240, 320, CV_8UC3, cv::Scalar::all(0)), right(480, 640, CV_8UC3);
  EXPECT_FALSE(vga.process(small, right, {}, {}, std::nullopt, &frame, &why));
  EXPECT_NE(why.find("left image is not BGR8 of the rig's 640x480"), std::string::npos) << why;
  perception::DepthParams never;
  never.match_max_width_px = 0;
  const StereoRig full_hd = StereoRig::makeDefault().atSize(1920, 1080);
  EXPECT_EQ(perception::DepthEstimator(full_hd, {}).decimation(), 2);
  EXPECT_EQ(perception::DepthEstimator(full_hd, never).decimation(), 1);
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

// makeCloud packs the points as pcl::toPCLPointCloud2 packs pcl::PointXYZRGB, in place; a
// CloudMaker reused for a smaller cloud leaves nothing of the larger one.
TEST(Cloud, PackedAsPclPacksIt) {
  const std::vector<cv::Point3f> points = {{0.5f, -1.25f, 3.0f}, {-2.0f, 0.125f, 7.5f}};
  const std::vector<cv::Vec3b> colours = {{1, 2, 3}, {250, 128, 0}};
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  for (size_t i = 0; i < points.size(); ++i) {
    pcl::PointXYZRGB q(colours[i][2], colours[i][1], colours[i][0]);
    q.x = points[i].x;
    q.y = points[i].y;
    q.z = points[i].z;
    cloud.push_back(q);
  }
  pcl::PCLPointCloud2 theirs;
  pcl::toPCLPointCloud2(cloud, theirs);
  perception::CloudParams none;
  none.voxel_size_m = 0;
  perception::CloudMaker maker(none);
  ptzstereo::point_cloud_t ours;
  maker.make({{9, 9, 9}, {9, 9, 9}, {9, 9, 9}}, {{9, 9, 9}, {9, 9, 9}, {9, 9, 9}}, &ours);
  maker.make(points, colours, &ours);
  EXPECT_EQ(ours.width, static_cast<int32_t>(theirs.width));
  EXPECT_EQ(ours.height, static_cast<int32_t>(theirs.height));
  EXPECT_EQ(ours.point_step, static_cast<int32_t>(theirs.point_step));
  EXPECT_EQ(ours.row_step, static_cast<int32_t>(theirs.row_step));
  EXPECT_EQ(ours.is_dense, theirs.is_dense);
  ASSERT_EQ(ours.fields.size(), theirs.fields.size());
  ASSERT_EQ(ours.num_fields, static_cast<int32_t>(ours.fields.size()));
  for (size_t f = 0; f < ours.fields.size(); ++f) {
    const auto& a = ours.fields[f];
    const auto& b = theirs.fields[f];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.offset, static_cast<int32_t>(b.offset)) << a.name;
    EXPECT_EQ(a.datatype, static_cast<int8_t>(b.datatype)) << a.name;
    EXPECT_EQ(a.count, static_cast<int32_t>(b.count)) << a.name;
    for (size_t i = 0; i < points.size(); ++i) {  // the field's bytes (padding aside)
      const size_t at = i * theirs.point_step + b.offset;
      EXPECT_EQ(std::memcmp(ours.data.data() + at, theirs.data.data() + at, 4), 0) << a.name;
    }
  }
  ASSERT_EQ(ours.data_size, static_cast<int32_t>(theirs.data.size()));
  ASSERT_EQ(ours.data.size(), theirs.data.size());
}

// makeCloud's voxel grid is PCL's VoxelGrid: the same voxels in the same order, their centroids
// (up to the order of the sums) and their colours.
TEST(Cloud, VoxelGridIsPcls) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), z(1.0f, 6.0f);
  std::uniform_int_distribution<int> c(0, 255);
  std::vector<cv::Point3f> points;
  std::vector<cv::Vec3b> colours;
  for (int i = 0; i < 20000; ++i) {
    const float depth = z(rng);
    points.emplace_back(u(rng) * depth, u(rng) * depth * 0.5f, depth);
    colours.emplace_back(c(rng), c(rng), c(rng));
  }
  for (double leaf_m : {0.05, 0.2, 1e-5}) {  // the last too small for 32-bit voxel indices
    std::vector<cv::Point3f> ours;
    std::vector<cv::Vec3b> our_colours;
    perception::voxelGridFilter(points, colours, leaf_m, &ours, &our_colours);
    pcl::PointCloud<pcl::PointXYZRGB>::Ptr in(new pcl::PointCloud<pcl::PointXYZRGB>);
    for (size_t i = 0; i < points.size(); ++i) {
      pcl::PointXYZRGB q;
      q.x = points[i].x;
      q.y = points[i].y;
      q.z = points[i].z;
      q.b = colours[i][0];
      q.g = colours[i][1];
      q.r = colours[i][2];
      in->push_back(q);
    }
    pcl::PointCloud<pcl::PointXYZRGB> theirs;
    pcl::VoxelGrid<pcl::PointXYZRGB> grid;
    const float leaf = static_cast<float>(leaf_m);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.setInputCloud(in);
    grid.filter(theirs);
    ASSERT_EQ(ours.size(), theirs.size()) << leaf_m;
    ASSERT_EQ(our_colours.size(), ours.size());
    for (size_t i = 0; i < ours.size(); ++i) {
      const pcl::PointXYZRGB& t = theirs[i];
      ASSERT_NEAR(ours[i].x, t.x, 1e-5) << leaf_m << " voxel " << i;
      ASSERT_NEAR(ours[i].y, t.y, 1e-5) << leaf_m << " voxel " << i;
      ASSERT_NEAR(ours[i].z, t.z, 1e-5) << leaf_m << " voxel " << i;
      ASSERT_EQ(our_colours[i], cv::Vec3b(t.b, t.g, t.r)) << leaf_m << " voxel " << i;
    }
    std::printf("leaf %g m: %zu points in %zu voxels, as PCL's\n", leaf_m, points.size(),
                ours.size());
  }
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

TEST(Cloud, PcdPathDueEveryNthCloudWithItsSeq) {
  using perception::pcdPathIfDue;
  EXPECT_EQ(pcdPathIfDue("c{seq}.pcd", 0, 1, 42), "c42.pcd");  // 0: the first only
  EXPECT_EQ(pcdPathIfDue("c{seq}.pcd", 0, 2, 43), "");
  EXPECT_EQ(pcdPathIfDue("c{seq}.pcd", 30, 31, 100), "c100.pcd");  // the 1st, 31st, 61st, ...
  EXPECT_EQ(pcdPathIfDue("c{seq}.pcd", 30, 30, 99), "");
  EXPECT_EQ(pcdPathIfDue("scene.pcd", 30, 61, 7), "scene.pcd");
  EXPECT_EQ(pcdPathIfDue("", 1, 1, 7), "");
}

TEST(Depth, DisparityGreySpansTheSearchRangeAndBlanksTheInvalid) {
  perception::DepthFrame frame;
  frame.min_disparity_px = 8;
  // 16ths of a pixel: invalid (below the range), the range's ends and its middle.
  frame.disparity_16s = (cv::Mat_<int16_t>(1, 4) << 7 * 16, 8 * 16, 40 * 16, 72 * 16);
  const cv::Mat grey = perception::disparityGrey(frame, 64);
  EXPECT_EQ(grey.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(grey.at<uint8_t>(0, 1), 0);
  EXPECT_EQ(grey.at<uint8_t>(0, 2), 128);  // 255 * 32 / 64 = 127.5, rounded half to even
  EXPECT_EQ(grey.at<uint8_t>(0, 3), 255);
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
