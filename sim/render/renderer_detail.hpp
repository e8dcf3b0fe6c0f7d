// What the renderer's files share (renderer.cpp, renderer_background.cpp, renderer_objects.cpp):
// the texture atlas's size and the one shading of a matte surface.
#pragma once

#include <opencv2/core.hpp>

#include <Eigen/Core>

#include <algorithm>

namespace ptz::sim::detail {

constexpr int kTextureSize = 1024;  // a power of two: wrap-around by masking

// A matte surface of colour base lit from to_light (unit): an ambient 0.45 and 0.55 direct.
inline cv::Vec3b shade(const cv::Vec3b& base, const Eigen::Vector3d& normal,
                       const Eigen::Vector3d& to_light) {
  const double intensity = 0.45 + 0.55 * std::max(0.0, normal.dot(to_light));
  return cv::Vec3b(cv::saturate_cast<uchar>(base[0] * intensity),
                   cv::saturate_cast<uchar>(base[1] * intensity),
                   cv::saturate_cast<uchar>(base[2] * intensity));
}

}  // namespace ptz::sim::detail
