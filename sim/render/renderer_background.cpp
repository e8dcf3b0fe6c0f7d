// The renderer's background: the backdrop and floor from the texture atlas, the objects' shadows
// on the floor, and the posters on the backdrop.
#include "sim/render/renderer.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/render/renderer_detail.hpp"
#include "sim/scene/pictures.hpp"

namespace ptz::sim {

using detail::kTextureSize;
using detail::shade;

void Renderer::drawBackground(const CameraView& view, const RayRows& rays,
                              const cv::Rect& board_rect, int row0, int row1, cv::Mat* bgr) {
  // Per pixel, where its ray meets the floor or the backdrop, as fixed-point coordinates into
  // the texture atlas (OpenCV's remap format: integer texel plus a 1/32 texel fraction);
  // cv::remap then samples it bilinearly, vectorised.
  const Eigen::Matrix3f R = view.rotation_head_camera.cast<float>();
  const Eigen::Vector3f C = view.position_head_m.cast<float>();
  const float zb = static_cast<float>(scene_.backdrop_distance_m);
  const float yf = static_cast<float>(scene_.floor_height_m);
  constexpr int kSub = cv::INTER_TAB_SIZE;  // 32 steps per texel
  const double scale = kSub / scene_.texture_m_per_texel;
  constexpr int kWrapMask = kTextureSize * kSub - 1;
  // A large multiple of the texture size keeps coordinates positive before the cast truncates,
  // so truncation is floor and the mask wraps.
  constexpr double kOffset = 4096.0 * kTextureSize * kSub + 0.5;
  auto fixed = [&](float metres) {
    // Rays that graze the floor meet it very far out: clamp before the cast can overflow.
    const double m = std::clamp(static_cast<double>(metres), -1e6, 1e6);
    return static_cast<int64_t>(m * scale + kOffset) & kWrapMask;
  };
  const short floor_row = kTextureSize + 1;  // the floor's half of the atlas
  for (int v = row0; v < row1; ++v) {
    const cv::Vec2f* ray_row = rays.row(v);
    cv::Vec2s* xy_row = map_xy_.ptr<cv::Vec2s>(v);
    uint16_t* frac_row = map_frac_.ptr<uint16_t>(v);
    float* depth_row = background_depth_.ptr<float>(v);
    for (int u = 0; u < view.width; ++u) {
      const Eigen::Vector3f d = R * Eigen::Vector3f(ray_row[u][0], ray_row[u][1], 1.0f);
      const float tf = (yf - C.y()) / d.y();
      const float tb = (zb - C.z()) / d.z();
      int64_t fx = 0, fy = 0;
      short atlas_row = 0;
      if (d.y() > 0 && tf > 0 && C.z() + tf * d.z() < zb) {
        fx = fixed(C.x() + tf * d.x());
        fy = fixed(C.z() + tf * d.z());
        atlas_row = floor_row;
        depth_row[u] = tf;
      } else if (d.z() > 0 && tb > 0) {
        fx = fixed(C.x() + tb * d.x());
        fy = fixed(C.y() + tb * d.y());
        depth_row[u] = tb;
      } else {
        xy_row[u] = cv::Vec2s(-100, -100);  // outside the atlas: the sky colour
        frac_row[u] = 0;
        depth_row[u] = std::numeric_limits<float>::infinity();
        continue;
      }
      xy_row[u] =
          cv::Vec2s(static_cast<short>(fx / kSub), static_cast<short>(atlas_row + fy / kSub));
      frac_row[u] = static_cast<uint16_t>((fy % kSub) * kSub + (fx % kSub));
    }
  }
  cv::Mat out = bgr->rowRange(row0, row1);
  cv::remap(atlas_, out, map_xy_.rowRange(row0, row1), map_frac_.rowRange(row0, row1),
            cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(200, 190, 180));
  if (!scene_.posters.empty()) drawPosters(view, rays, row0, row1, bgr);
  if (scene_.chessboard.present) drawChessboard(view, rays, board_rect, row0, row1, bgr);
}

void Renderer::drawShadows(const CameraView& view, const RayRows& rays, int row0, int row1,
                           cv::Mat* bgr) {
  const Eigen::Matrix3d& R = view.rotation_head_camera;
  const Eigen::Vector3d& C = view.position_head_m;
  const double yf = scene_.floor_height_m;
  const double keep = 1 - scene_.light.shadow_depth;
  const cv::Rect rows_rect(0, row0, view.width, row1 - row0);
  const size_t n = objects_.size();
  for (size_t i = 0; i < n; ++i) {
    const cv::Rect r = objects_[i].shadow_rect & rows_rect;
    for (int v = r.y; v < r.y + r.height; ++v) {
      const cv::Vec2f* ray_row = rays.row(v);
      const cv::Vec2s* xy_row = map_xy_.ptr<cv::Vec2s>(v);
      const float* depth_row = background_depth_.ptr<float>(v);
      cv::Vec3b* out = bgr->ptr<cv::Vec3b>(v);
      for (int u = r.x; u < r.x + r.width; ++u) {
        // A pixel in several objects' rectangles is the first one's: darkened once.
        bool earlier = false;
        for (size_t j = 0; j < i && !earlier; ++j) {
          earlier = objects_[j].shadow_rect.contains({u, v});
        }
        // Only where drawBackground drew the floor (its atlas rows) and nothing of the background
        // (the chessboard) stands in front of it.
        if (earlier || xy_row[u][1] <= kTextureSize) continue;
        const Eigen::Vector3d d = R * Eigen::Vector3d(ray_row[u][0], ray_row[u][1], 1.0);
        if (!(d.y() > 0)) continue;
        const double tf = (yf - C.y()) / d.y();
        if (!(tf > 0) || depth_row[u] < tf * (1 - 1e-3)) continue;
        const Eigen::Vector3d p = C + tf * d;
        for (size_t j = i; j < n; ++j) {
          if (!objects_[j].shadow_rect.contains({u, v}) ||
              !blocksLight(scene_.objects[j], objects_[j], p)) {
            continue;
          }
          for (int k = 0; k < 3; ++k) out[u][k] = cv::saturate_cast<uchar>(out[u][k] * keep);
          break;
        }
      }
    }
  }
}

bool Renderer::blocksLight(const SceneObject& object, const ObjectFrame& frame,
                           const Eigen::Vector3d& p) const {
  const Eigen::Vector3d& l = to_light_;
  const Eigen::Vector3d o = p - frame.centre;
  switch (object.shape) {
    case SceneObject::Shape::kSphere: {
      // |o + s l| = r for some s > 0 (l unit): the far root ahead.
      const double b = o.dot(l), c = o.squaredNorm() - object.radius_m * object.radius_m;
      const double disc = b * b - c;
      return disc >= 0 && -b + std::sqrt(disc) > 0;
    }
    case SceneObject::Shape::kBox: {
      const Eigen::Vector3d q = frame.box_to_head.transpose() * o;
      const Eigen::Vector3d dq = frame.box_to_head.transpose() * l;
      double s_near = 0, s_far = 1e30;  // ahead of the floor point only
      for (int k = 0; k < 3; ++k) {
        const double h = object.half_extents_m[k];
        if (std::abs(dq[k]) < 1e-12) {
          if (std::abs(q[k]) > h) return false;
          continue;
        }
        double s0 = (-h - q[k]) / dq[k], s1 = (h - q[k]) / dq[k];
        if (s0 > s1) std::swap(s0, s1);
        s_near = std::max(s_near, s0);
        s_far = std::min(s_far, s1);
      }
      return s_near <= s_far;
    }
    case SceneObject::Shape::kPerson: {
      // The figure's own outline: where the way to the light crosses its plane, its alpha.
      const Eigen::Vector3d q = frame.box_to_head.transpose() * o;
      const Eigen::Vector3d dq = frame.box_to_head.transpose() * l;
      if (std::abs(dq.z()) < 1e-12) return false;
      const double s = -q.z() / dq.z();
      if (s <= 0) return false;
      const Eigen::Vector3d at = q + s * dq;
      const cv::Mat& picture = frame.picture;
      const int col =
          static_cast<int>(std::floor((at.x() / (object.height_m / 2) + 0.5) * picture.cols));
      const int row = static_cast<int>(std::floor((at.y() / object.height_m + 0.5) * picture.rows));
      return col >= 0 && row >= 0 && col < picture.cols && row < picture.rows &&
             picture.at<cv::Vec4b>(row, col)[3] >= 128;
    }
  }
  return false;
}

void Renderer::drawPosters(const CameraView& view, const RayRows& rays, int row0, int row1,
                           cv::Mat* bgr) {
  const Eigen::Matrix3d& R = view.rotation_head_camera;
  const Eigen::Vector3d& C = view.position_head_m;
  const double zb = scene_.backdrop_distance_m;
  // Where a ray meets the backdrop plane (x, y); false when the plane is not ahead along it.
  auto meet = [&](const cv::Vec2f& ray, Eigen::Vector2d* xy) {
    const Eigen::Vector3d d = R * Eigen::Vector3d(ray[0], ray[1], 1);
    const double t = (zb - C.z()) / d.z();
    if (!(d.z() > 0 && t > 0)) return false;
    *xy = {C.x() + t * d.x(), C.y() + t * d.y()};
    return true;
  };
  // Most pixels of a view with small posters are passed over with four comparisons.
  const size_t n = std::min(scene_.posters.size(), Poster::kMax);
  std::array<RayBox, Poster::kMax> boxes;
  RayBox any;
  for (size_t i = 0; i < n; ++i) {
    boxes[i] = RayBox::of(scene_.posters[i], view, zb);
    any.add(boxes[i]);
  }
  for (int v = row0; v < row1; ++v) {
    const cv::Vec2f* ray_row = rays.row(v);
    const cv::Vec2s* xy_row = map_xy_.ptr<cv::Vec2s>(v);
    cv::Vec3b* out = bgr->ptr<cv::Vec3b>(v);
    for (int u = 0; u < view.width; ++u) {
      const cv::Vec2f& ray = ray_row[u];
      if (!any.contains(ray[0], ray[1])) continue;
      // Only where drawBackground drew the backdrop: its atlas rows, not the floor's or the sky.
      if (xy_row[u][1] < 0 || xy_row[u][1] > kTextureSize) continue;
      Eigen::Vector2d p;
      bool met = false;
      // The last poster in the list is in front.
      for (size_t i = n; i-- > 0;) {
        if (!boxes[i].contains(ray[0], ray[1])) continue;
        if (!met && !(met = meet(ray, &p))) break;
        const Poster& poster = scene_.posters[i];
        if (!poster.contains(p.x(), p.y())) continue;
        // A photograph's pixel: its footprint, the distance to its neighbour's point.
        Eigen::Vector2d q = p;
        if (poster.isPhotograph()) {
          meet(ray_row[u + 1 < view.width ? u + 1 : std::max(0, u - 1)], &q);
        }
        out[u] = poster.shade(p.x(), p.y(), (q - p).norm(), out[u]);
        break;
      }
    }
  }
}

}  // namespace ptz::sim
