#include "perception/detect/stereo.hpp"

#include <opencv2/calib3d.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace ptz::perception {

Eigen::Vector3d pixelRay(const CameraView& view, const Eigen::Vector2d& pixel) {
  const Intrinsics& k = view.intrinsics;
  std::vector<cv::Point2d> in{{pixel.x(), pixel.y()}}, out;
  cv::undistortPoints(in, out, cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1),
                      std::vector<double>(k.distortion.begin(), k.distortion.end()), cv::noArray(),
                      cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12));
  return (view.rotation_head_camera * Eigen::Vector3d(out[0].x, out[0].y, 1.0)).normalized();
}

bool triangulate(const CameraView& left, const CameraView& right, const Eigen::Vector2d& left_px,
                 const Eigen::Vector2d& right_px, Eigen::Vector3d* point_head,
                 double* epipolar_px) {
  const Eigen::Vector3d dl = pixelRay(left, left_px), dr = pixelRay(right, right_px);
  const Eigen::Vector3d cl = left.position_head_m, cr = right.position_head_m;
  // Closest points cl + s dl and cr + t dr: solve the 2x2 normal equations.
  const Eigen::Vector3d w = cl - cr;
  const double b = dl.dot(dr), d = dl.dot(w), e = dr.dot(w);
  const double denom = 1.0 - b * b;
  if (denom < 1e-12) return false;
  const double s = (b * e - d) / denom, t = (e - b * d) / denom;
  if (s <= 0 || t <= 0) return false;
  const Eigen::Vector3d pl = cl + s * dl, pr = cr + t * dr;
  *point_head = (pl + pr) / 2;
  if (epipolar_px) {
    // The gap between the rays seen from the right camera, in its pixels.
    *epipolar_px = (pl - pr).norm() / t * right.intrinsics.fx;
  }
  return true;
}

Eigen::Matrix3d triangulationCovariance(const CameraView& left, const CameraView& right,
                                        const Eigen::Vector2d& left_px,
                                        const Eigen::Vector2d& right_px, double sigma_px) {
  Eigen::Vector3d p0;
  if (!triangulate(left, right, left_px, right_px, &p0)) return Eigen::Matrix3d::Constant(NAN);
  Eigen::Matrix<double, 3, 4> J;
  constexpr double h = 0.01;  // px
  for (int i = 0; i < 4; ++i) {
    Eigen::Vector2d l = left_px, r = right_px;
    (i < 2 ? l : r)[i % 2] += h;
    Eigen::Vector3d p;
    if (!triangulate(left, right, l, r, &p)) return Eigen::Matrix3d::Constant(NAN);
    J.col(i) = (p - p0) / h;
  }
  return sigma_px * sigma_px * J * J.transpose();
}

std::vector<StereoObject> associate(const std::vector<Region>& left,
                                    const std::vector<Region>& right, const CameraView& left_view,
                                    const CameraView& right_view, const StereoParams& params) {
  std::vector<StereoObject> candidates;
  // Areas scale with the focal length squared: compare them as if both had the left's zoom.
  const double area_scale = std::pow(left_view.intrinsics.fx / right_view.intrinsics.fx, 2);
  for (size_t i = 0; i < left.size(); ++i) {
    for (size_t j = 0; j < right.size(); ++j) {
      if (left[i].class_index != right[j].class_index) continue;
      const double ratio = left[i].area_px2 / (right[j].area_px2 * area_scale);
      if (ratio > params.max_area_ratio || ratio < 1.0 / params.max_area_ratio) continue;
      StereoObject o;
      const Eigen::Vector2d pl(left[i].centroid_px.x, left[i].centroid_px.y);
      const Eigen::Vector2d pr(right[j].centroid_px.x, right[j].centroid_px.y);
      if (!triangulate(left_view, right_view, pl, pr, &o.position_head_m, &o.epipolar_px)) continue;
      if (o.epipolar_px > params.max_epipolar_px) continue;
      const double range = (o.position_head_m - left_view.position_head_m).norm();
      if (range < params.min_range_m || range > params.max_range_m) continue;
      o.left = static_cast<int>(i);
      o.right = static_cast<int>(j);
      o.class_index = left[i].class_index;
      candidates.push_back(o);
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const StereoObject& a, const StereoObject& b) {
    return a.epipolar_px < b.epipolar_px;
  });
  std::vector<StereoObject> out;
  std::vector<bool> used_left(left.size()), used_right(right.size());
  for (auto& o : candidates) {
    if (used_left[o.left] || used_right[o.right]) continue;
    used_left[o.left] = used_right[o.right] = true;
    o.covariance_m2 = triangulationCovariance(
        left_view, right_view, {left[o.left].centroid_px.x, left[o.left].centroid_px.y},
        {right[o.right].centroid_px.x, right[o.right].centroid_px.y}, params.pixel_sigma_px);
    out.push_back(o);
  }
  return out;
}

}  // namespace ptz::perception
