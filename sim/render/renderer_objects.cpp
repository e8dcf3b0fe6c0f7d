// The renderer's objects: spheres, boxes with their prints, people's figures, the chessboard.
#include "sim/render/renderer.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/render/renderer_detail.hpp"
#include "sim/scene/pictures.hpp"

namespace ptz::sim {
namespace {

using detail::kTextureSize;

// Bilinear grey level of the texture atlas's backdrop at texel (x, y), wrapped, 0..1-ish.
double textureLevel(const cv::Mat& atlas, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  auto at = [&](int xx, int yy) {
    return atlas.at<cv::Vec3b>(yy & (kTextureSize - 1), xx & (kTextureSize - 1))[1] / 128.0;
  };
  const double ax = x - fx, ay = y - fy;
  return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x0 + 1, y0)) +
         ay * ((1 - ax) * at(x0, y0 + 1) + ax * at(x0 + 1, y0 + 1));
}

}  // namespace

using detail::shade;

std::array<cv::Point, Renderer::kSubRays * Renderer::kSubRays> Renderer::subRayCells(
    const ObjectFrame& frame, const Eigen::Matrix3d& R, const RayRows& rays, const CameraView& view,
    int u, int v, const PicturePlane& plane) {
  // The ray's change along the row, and down the column as the same turned by a right angle
  // (scaled by fx / fy): a band holds its own rows only, and the image must not depend on bands.
  const int u1 = std::min(u + 1, view.width - 1), u0 = std::max(u - 1, 0);
  const cv::Vec2f& rc = rays.row(v)[u];
  const cv::Vec2f gx =
      (rays.row(v)[u1] - rays.row(v)[u0]) * (1.0f / static_cast<float>(std::max(1, u1 - u0)));
  const float aspect = static_cast<float>(view.intrinsics.fx / view.intrinsics.fy);
  const cv::Vec2f gy(-gx[1] * aspect, gx[0] * aspect);
  const Eigen::Vector3d n = plane.axes.col(2);
  const double distance = n.dot(plane.centre_m - frame.oc_box);
  const double cell_x_m = plane.width_m / plane.cols, cell_y_m = plane.height_m / plane.rows;
  std::array<cv::Point, kSubRays * kSubRays> cells;
  for (int s = 0; s < kSubRays * kSubRays; ++s) {
    cells[static_cast<size_t>(s)] = {-1, -1};
    const float su = (static_cast<float>(s % kSubRays) + 0.5f) / kSubRays - 0.5f;
    const float sv = (static_cast<float>(s / kSubRays) + 0.5f) / kSubRays - 0.5f;
    const cv::Vec2f r = rc + gx * su + gy * sv;
    const Eigen::Vector3d db = frame.box_to_head.transpose() * (R * Eigen::Vector3d(r[0], r[1], 1));
    const double den = n.dot(db);
    if (std::abs(den) < 1e-12) continue;
    const Eigen::Vector3d q =
        plane.axes.transpose() * (frame.oc_box + (distance / den) * db - plane.centre_m);
    const double col = std::floor((q.x() + plane.width_m / 2) / cell_x_m),
                 row = std::floor((q.y() + plane.height_m / 2) / cell_y_m);
    if (col >= 0 && row >= 0 && col < plane.cols && row < plane.rows) {
      cells[static_cast<size_t>(s)] = {static_cast<int>(col), static_cast<int>(row)};
    }
  }
  return cells;
}

cv::Vec3f Renderer::printReflectance(const SceneObject& object, const ObjectFrame& frame,
                                     const Eigen::Matrix3d& R, const RayRows& rays,
                                     const CameraView& view, int u, int v,
                                     const Eigen::Vector3d& p_box, const Eigen::Vector3d& inward,
                                     double t) {
  // A tag's black is the face's colour this dark (ink on a matt face).
  constexpr float kInk = 0.08f;
  const cv::Vec2f& g = rays.row(v)[std::min(u + 1, view.width - 1)];
  const double footprint_m = 2 * t * (cv::norm(g - rays.row(v)[u]) + 1e-3);
  for (const SceneTag& tag : object.tags) {
    const Eigen::Matrix3d& Rt = tag.rotation_object_tag;
    if (Rt.col(2).dot(inward) < 0.99) continue;  // on another face
    const cv::Mat& picture = tag.isMarker() ? tag.cells : tag.picture;
    PicturePlane plane{tag.centre_m, Rt,
                       tag.size_m,   tag.size_m * picture.rows / picture.cols,
                       picture.cols, picture.rows};
    const Eigen::Vector3d q = Rt.transpose() * (p_box - tag.centre_m);
    if (std::abs(q.x()) > plane.width_m / 2 + footprint_m ||
        std::abs(q.y()) > plane.height_m / 2 + footprint_m) {
      continue;
    }
    cv::Vec3f sum(0, 0, 0);
    for (const cv::Point& c : subRayCells(frame, R, rays, view, u, v, plane)) {
      if (c.x < 0) {
        sum += cv::Vec3f(1, 1, 1);
      } else if (tag.isMarker()) {
        const float white = picture.at<uchar>(c) / 255.0f;
        sum += cv::Vec3f::all(kInk + (1 - kInk) * white);
      } else {
        const cv::Vec3b& p = picture.at<cv::Vec3b>(c);
        sum += cv::Vec3f(p[0], p[1], p[2]) * (1.0f / 255);
      }
    }
    return sum * (1.0f / (kSubRays * kSubRays));
  }
  return {1, 1, 1};
}

int64_t Renderer::drawPerson(const SceneObject& object, const ObjectFrame& frame, int32_t index,
                             const CameraView& view, const RayRows& rays, int v0, int v1,
                             cv::Mat* bgr) {
  const cv::Rect& rect = frame.rect;
  const Eigen::Matrix3d& R = view.rotation_head_camera;
  const PicturePlane plane{Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(),
                           object.height_m / 2,     object.height_m,
                           frame.picture.cols,      frame.picture.rows};
  int64_t footprint = 0;
  for (int v = v0; v < v1; ++v) {
    const cv::Vec2f* ray_row = rays.row(v);
    const auto [out, out_depth, out_owner] = objectRow(bgr, v);
    for (int u = rect.x; u < rect.x + rect.width; ++u) {
      const Eigen::Vector3d db =
          frame.box_to_head.transpose() * (R * Eigen::Vector3d(ray_row[u][0], ray_row[u][1], 1));
      if (std::abs(db.z()) < 1e-12) continue;
      const double t = -frame.oc_box.z() / db.z();
      if (t <= 0) continue;
      const Eigen::Vector3d p = frame.oc_box + t * db;
      const double margin_m = 0.02 * object.height_m;
      if (std::abs(p.x()) > plane.width_m / 2 + margin_m ||
          std::abs(p.y()) > plane.height_m / 2 + margin_m) {
        continue;
      }
      // The pixel's size on the picture, in cells: small enough, and away from the outline, its
      // centre's cell is the whole pixel's colour.
      const int u1 = std::min(u + 1, view.width - 1);
      const double pixel_cells =
          t * cv::norm(ray_row[u1] - ray_row[u]) * plane.rows / plane.height_m;
      const int col = static_cast<int>(std::floor((p.x() / plane.width_m + 0.5) * plane.cols));
      const int row = static_cast<int>(std::floor((p.y() / plane.height_m + 0.5) * plane.rows));
      cv::Vec4f sum(0, 0, 0, 0);
      if (pixel_cells < kEdgeCells && col >= 0 && row >= 0 && col < plane.cols &&
          row < plane.rows && frame.edge.at<uchar>(row, col) == 0) {
        const cv::Vec4b& q = frame.picture.at<cv::Vec4b>(row, col);
        sum = cv::Vec4f(q[0], q[1], q[2], q[3]) * (1.0f / 255);
      } else {
        for (const cv::Point& c : subRayCells(frame, R, rays, view, u, v, plane)) {
          if (c.x < 0) continue;
          const cv::Vec4b& q = frame.picture.at<cv::Vec4b>(c);
          sum += cv::Vec4f(q[0], q[1], q[2], q[3]);
        }
        sum *= 1.0f / (kSubRays * kSubRays * 255);
      }
      if (sum[3] < 0.5f) {
        if (sum[3] <= 0 || t >= out_depth[u]) continue;
      } else {
        ++footprint;
        if (t >= out_depth[u]) continue;
        out_depth[u] = static_cast<float>(t);
        out_owner[u] = index;
      }
      // Premultiplied colours over what is there (the figure's edges are antialiased).
      for (int k = 0; k < 3; ++k) {
        out[u][k] = cv::saturate_cast<uchar>(255 * sum[k] + (1 - sum[3]) * out[u][k]);
      }
    }
  }
  return footprint;
}

int64_t Renderer::drawObject(const SceneObject& object, const ObjectFrame& frame, int32_t index,
                             const CameraView& view, const RayRows& rays, int row0, int row1,
                             cv::Mat* bgr) {
  const cv::Rect& rect = frame.rect;
  const int v0 = std::max(rect.y, row0), v1 = std::min(rect.y + rect.height, row1);
  if (rect.empty() || v0 >= v1) return 0;
  if (object.shape == SceneObject::Shape::kPerson) {
    return drawPerson(object, frame, index, view, rays, v0, v1, bgr);
  }
  int64_t footprint = 0;
  const Eigen::Matrix3d& R = view.rotation_head_camera;
  const Eigen::Vector3d& oc = frame.oc;
  const Eigen::Matrix3d& box_to_head = frame.box_to_head;
  const Eigen::Vector3d& oc_box = frame.oc_box;
  const bool sphere = object.shape == SceneObject::Shape::kSphere;
  for (int v = v0; v < v1; ++v) {
    const cv::Vec2f* ray_row = rays.row(v);
    const auto [out, out_depth, out_owner] = objectRow(bgr, v);
    for (int u = rect.x; u < rect.x + rect.width; ++u) {
      const Eigen::Vector3d d = R * Eigen::Vector3d(ray_row[u][0], ray_row[u][1], 1.0);
      double t = -1;
      Eigen::Vector3d db;  // box: the ray in the box's frame
      int axis = -1;       // box: the axis of the face it meets
      if (sphere) {
        const double b = oc.dot(d), a = d.squaredNorm();
        const double disc = b * b - a * (oc.squaredNorm() - object.radius_m * object.radius_m);
        if (disc < 0) continue;
        t = (-b - std::sqrt(disc)) / a;
      } else {
        db = box_to_head.transpose() * d;
        double t_near = -1e30, t_far = 1e30;
        for (int k = 0; k < 3; ++k) {
          if (std::abs(db[k]) < 1e-12) {
            if (std::abs(oc_box[k]) > object.half_extents_m[k]) t_far = -1;
            continue;
          }
          double t0 = (-object.half_extents_m[k] - oc_box[k]) / db[k];
          double t1 = (object.half_extents_m[k] - oc_box[k]) / db[k];
          if (t0 > t1) std::swap(t0, t1);
          if (t0 > t_near) {
            t_near = t0;
            axis = k;
          }
          t_far = std::min(t_far, t1);
        }
        if (t_near > t_far || axis < 0) continue;
        t = t_near;
      }
      if (t <= 0) continue;
      ++footprint;
      if (t >= out_depth[u]) continue;
      // Shading only for the pixels it shows.
      // n_box: a box face's outward normal in the box's frame.
      Eigen::Vector3d normal, n_box = Eigen::Vector3d::Zero();
      Eigen::Vector2d surface_m;  // texture coordinates on the surface
      if (sphere) {
        normal = (oc + t * d) / object.radius_m;
        if (object.textured) {
          surface_m =
              object.radius_m * Eigen::Vector2d(std::atan2(normal.x(), -normal.z()),
                                                std::asin(std::clamp(normal.y(), -1.0, 1.0)));
        }
      } else {
        n_box = Eigen::Vector3d::Zero();
        n_box[axis] = db[axis] > 0 ? -1 : 1;
        normal = box_to_head * n_box;
        const Eigen::Vector3d p_box = oc_box + t * db;
        surface_m = {p_box[(axis + 1) % 3], p_box[(axis + 2) % 3]};
      }
      out_depth[u] = static_cast<float>(t);
      out_owner[u] = index;
      out[u] = shade(object.color_bgr, normal, to_light_);
      if (object.textured) {
        // Four times finer than the backdrop: objects are small, and the texture's coarse
        // scales would only shade them.
        const double texel_m = scene_.texture_m_per_texel / 4;
        const double level = textureLevel(atlas_, surface_m.x() / texel_m, surface_m.y() / texel_m);
        out[u] = out[u] * (0.5 + 0.5 * level);
      }
      if (!sphere && !object.tags.empty()) {
        const cv::Vec3f reflectance =
            printReflectance(object, frame, R, rays, view, u, v, oc_box + t * db, -n_box, t);
        for (int k = 0; k < 3; ++k) {
          out[u][k] = cv::saturate_cast<uchar>(out[u][k] * reflectance[k]);
        }
      }
    }
  }
  return footprint;
}

void Renderer::drawChessboard(const CameraView& view, const RayRows& rays, const cv::Rect& rect,
                              int row0, int row1, cv::Mat* bgr) {
  const Chessboard& b = scene_.chessboard;
  // The board with a white margin of one square around the (inner + 1) squares (as render()).
  const double half_w = (b.inner_cols + 3) * b.square_m / 2;
  const double half_h = (b.inner_rows + 3) * b.square_m / 2;
  const int v_begin = std::max(rect.y, row0), v_end = std::min(rect.y + rect.height, row1);
  if (rect.empty() || v_begin >= v_end) return;
  const Eigen::Matrix3d& R = view.rotation_head_camera;
  const Eigen::Matrix3d Rb = b.rotation_head_board.transpose();
  const Eigen::Vector3d o = Rb * (view.position_head_m - b.centre_head_m);
  // Corner (0,0) of the squares grid sits at -(inner + 1)/2 squares from the centre.
  const double x0 = -(b.inner_cols + 1) * b.square_m / 2, y0 = -(b.inner_rows + 1) * b.square_m / 2;
  constexpr int kSub = 4;  // supersampling so corner positions are sub-pixel exact
  for (int v = v_begin; v < v_end; ++v) {
    cv::Vec3b* out = bgr->ptr<cv::Vec3b>(v);
    float* out_depth = background_depth_.ptr<float>(v);
    for (int u = rect.x; u < rect.x + rect.width; ++u) {
      int hits = 0, white = 0;
      double t_centre = -1;
      // Rays between pixel centres: interpolate the ray map.
      const int u1 = std::min(u + 1, view.width - 1), v1 = std::min(v + 1, view.height - 1);
      const int u0 = std::max(u - 1, 0), v0 = std::max(v - 1, 0);
      const cv::Vec2f& rc = rays.row(v)[u];
      const cv::Vec2f gx =
          (rays.row(v)[u1] - rays.row(v)[u0]) * (1.0f / static_cast<float>(std::max(1, u1 - u0)));
      const cv::Vec2f gy =
          (rays.row(v1)[u] - rays.row(v0)[u]) * (1.0f / static_cast<float>(std::max(1, v1 - v0)));
      for (int s = 0; s < kSub * kSub; ++s) {
        const double du = ((s % kSub) + 0.5) / kSub - 0.5, dv = ((s / kSub) + 0.5) / kSub - 0.5;
        const cv::Vec2f r = rc + gx * static_cast<float>(du) + gy * static_cast<float>(dv);
        const Eigen::Vector3d d = Rb * (R * Eigen::Vector3d(r[0], r[1], 1.0));
        if (std::abs(d.z()) < 1e-12) continue;
        const double t = -o.z() / d.z();
        if (t <= 0) continue;
        const double x = o.x() + t * d.x(), y = o.y() + t * d.y();
        if (std::abs(x) > half_w || std::abs(y) > half_h) continue;
        ++hits;
        if (t_centre < 0) t_centre = t;
        const int cx = static_cast<int>(std::floor((x - x0) / b.square_m));
        const int cy = static_cast<int>(std::floor((y - y0) / b.square_m));
        const bool inside = cx >= 0 && cy >= 0 && cx <= b.inner_cols && cy <= b.inner_rows;
        if (!inside || ((cx + cy) % 2 == 1)) ++white;
      }
      if (hits == 0 || t_centre >= out_depth[u]) continue;
      const double coverage = static_cast<double>(hits) / (kSub * kSub);
      const double level = 20 + 215.0 * white / hits;
      for (int k = 0; k < 3; ++k) {
        out[u][k] = cv::saturate_cast<uchar>(coverage * level + (1 - coverage) * out[u][k]);
      }
      out_depth[u] = static_cast<float>(t_centre);
    }
  }
}

}  // namespace ptz::sim
