#include "sim/renderer.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace ptz::sim {
namespace {

constexpr int kTextureSize = 1024;  // a power of two: wrap-around by masking
// Undistortion solved every 8 px and interpolated between: within 0.01 px of solving every
// pixel for the default lens, at a sixty-fourth of the cost (zoom changes it every frame).
constexpr int kGridStep = 8;

// Low-saturation multi-scale noise with a few darker patches: texture for block matching that
// does not look like any object colour.
cv::Mat makeTexture(unsigned seed, cv::Vec3f tint) {
  cv::RNG rng(seed);
  cv::Mat acc(kTextureSize, kTextureSize, CV_32F, cv::Scalar(0));
  float weight = 1.0f;
  for (int cells = 8; cells <= 512; cells *= 2) {
    // Wrap-padded before upsampling, so the texture tiles without seams.
    cv::Mat small(cells, cells, CV_32F), padded, big;
    rng.fill(small, cv::RNG::UNIFORM, -1.0, 1.0);
    cv::copyMakeBorder(small, padded, 2, 2, 2, 2, cv::BORDER_WRAP);
    const int scale = kTextureSize / cells;
    cv::resize(padded, big, padded.size() * scale, 0, 0, cv::INTER_CUBIC);
    acc += weight * big(cv::Rect(2 * scale, 2 * scale, kTextureSize, kTextureSize));
    weight *= 0.75f;
  }
  cv::normalize(acc, acc, 40, 215, cv::NORM_MINMAX);
  cv::Mat out(kTextureSize, kTextureSize, CV_8UC3);
  for (int r = 0; r < kTextureSize; ++r) {
    for (int c = 0; c < kTextureSize; ++c) {
      const float v = acc.at<float>(r, c);
      out.at<cv::Vec3b>(r, c) =
          cv::Vec3b(cv::saturate_cast<uchar>(v * tint[0]), cv::saturate_cast<uchar>(v * tint[1]),
                    cv::saturate_cast<uchar>(v * tint[2]));
    }
  }
  return out;
}

bool sameIntrinsics(const Intrinsics& a, const Intrinsics& b) {
  return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy &&
         a.distortion == b.distortion;
}

cv::Vec3b shade(const cv::Vec3b& base, const Eigen::Vector3d& normal) {
  static const Eigen::Vector3d kToLight = Eigen::Vector3d(-0.3, -0.8, -0.5).normalized();
  const double intensity = 0.45 + 0.55 * std::max(0.0, normal.dot(kToLight));
  return cv::Vec3b(cv::saturate_cast<uchar>(base[0] * intensity),
                   cv::saturate_cast<uchar>(base[1] * intensity),
                   cv::saturate_cast<uchar>(base[2] * intensity));
}

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

// Pixel rectangle that holds the image of a sphere of radius r around p (head frame): the
// projections of a slightly larger sphere's surface, padded.
cv::Rect boundingRect(const CameraView& view, const Eigen::Vector3d& p, double r) {
  const Eigen::Vector3d pc = view.toCamera(p);
  const cv::Rect whole(0, 0, view.width, view.height);
  if (pc.z() + r <= 0) return {};
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (int i = 0; i <= 8; ++i) {
    const double lat = M_PI * i / 8 - M_PI / 2;
    for (int j = 0; j < 16; ++j) {
      const double lon = 2 * M_PI * j / 16;
      const Eigen::Vector3d q =
          pc + 1.25 * r *
                   Eigen::Vector3d(std::cos(lat) * std::cos(lon), std::sin(lat),
                                   std::cos(lat) * std::sin(lon));
      if (q.z() <= 1e-3) return whole;
      const Eigen::Vector2d px = view.projectCamera(q);
      u0 = std::min(u0, px.x());
      v0 = std::min(v0, px.y());
      u1 = std::max(u1, px.x());
      v1 = std::max(v1, px.y());
    }
  }
  const double pad = 2 + 0.1 * std::max(u1 - u0, v1 - v0);
  const cv::Point top_left(static_cast<int>(std::floor(std::max(u0 - pad, -1.0))),
                           static_cast<int>(std::floor(std::max(v0 - pad, -1.0))));
  const cv::Point bottom_right(static_cast<int>(std::ceil(std::min(u1 + pad, view.width + 1.0))),
                               static_cast<int>(std::ceil(std::min(v1 + pad, view.height + 1.0))));
  return cv::Rect(top_left, bottom_right) & whole;
}

}  // namespace

Renderer::Renderer(const Scene& scene) : scene_(scene) {
  // Atlas: backdrop above, floor below, each with one wrapped row and column so that bilinear
  // sampling at the last texel reads the first.
  cv::Mat backdrop, floor;
  cv::copyMakeBorder(makeTexture(scene.texture_seed, {0.95f, 1.0f, 1.05f}), backdrop, 0, 1, 0, 1,
                     cv::BORDER_WRAP);
  cv::copyMakeBorder(makeTexture(scene.texture_seed + 1, {0.85f, 0.95f, 1.05f}), floor, 0, 1, 0, 1,
                     cv::BORDER_WRAP);
  cv::vconcat(backdrop, floor, atlas_);
}

const cv::Mat& Renderer::rays(const CameraView& view) {
  for (auto& c : caches_) {
    if (c.width == view.width && c.height == view.height &&
        sameIntrinsics(c.intrinsics, view.intrinsics)) {
      return c.rays;
    }
  }
  const Intrinsics& k = view.intrinsics;
  const int gw = view.width / kGridStep + 2, gh = view.height / kGridStep + 2;
  std::vector<cv::Point2f> grid;
  grid.reserve(static_cast<size_t>(gw * gh));
  for (int j = 0; j < gh; ++j) {
    for (int i = 0; i < gw; ++i) grid.emplace_back(i * kGridStep, j * kGridStep);
  }
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  std::vector<cv::Point2f> undistorted;
  cv::undistortPoints(grid, undistorted, K, cv::Mat(k.distortion, true), cv::noArray(),
                      cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12));
  RayCache cache{view.width, view.height, k, cv::Mat(view.height, view.width, CV_32FC2)};
  for (int v = 0; v < view.height; ++v) {
    const int j = v / kGridStep;
    const float fv = static_cast<float>(v - j * kGridStep) / kGridStep;
    cv::Vec2f* row = cache.rays.ptr<cv::Vec2f>(v);
    for (int u = 0; u < view.width; ++u) {
      const int i = u / kGridStep;
      const float fu = static_cast<float>(u - i * kGridStep) / kGridStep;
      const cv::Point2f& a = undistorted[j * gw + i];
      const cv::Point2f& b = undistorted[j * gw + i + 1];
      const cv::Point2f& c = undistorted[(j + 1) * gw + i];
      const cv::Point2f& d = undistorted[(j + 1) * gw + i + 1];
      const cv::Point2f top = a + fu * (b - a), bottom = c + fu * (d - c);
      const cv::Point2f p = top + fv * (bottom - top);
      row[u] = cv::Vec2f(p.x, p.y);
    }
  }
  if (caches_.size() >= 4) caches_.erase(caches_.begin());
  caches_.push_back(std::move(cache));
  return caches_.back().rays;
}

void Renderer::render(const CameraView& view, double t_s, cv::Mat* bgr,
                      std::vector<double>* visible_fraction) {
  const cv::Mat& ray_map = rays(view);
  // Background: per pixel, where its ray meets the floor or the backdrop, as fixed-point
  // coordinates into the texture atlas (OpenCV's remap format: integer texel plus a 1/32 texel
  // fraction); cv::remap then samples it bilinearly, vectorised.
  map_xy_.create(view.height, view.width, CV_16SC2);
  map_frac_.create(view.height, view.width, CV_16UC1);
  depth_.create(view.height, view.width, CV_32F);
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
  for (int v = 0; v < view.height; ++v) {
    const cv::Vec2f* ray_row = ray_map.ptr<cv::Vec2f>(v);
    cv::Vec2s* xy_row = map_xy_.ptr<cv::Vec2s>(v);
    uint16_t* frac_row = map_frac_.ptr<uint16_t>(v);
    float* depth_row = depth_.ptr<float>(v);
    for (int u = 0; u < view.width; ++u) {
      const Eigen::Vector3f d = R * Eigen::Vector3f(ray_row[u][0], ray_row[u][1], 1.0f);
      const float tf = (yf - C.y()) / d.y();
      const float tb = (zb - C.z()) / d.z();
      int64_t fx = 0, fy = 0;
      short row0 = 0;
      if (d.y() > 0 && tf > 0 && C.z() + tf * d.z() < zb) {
        fx = fixed(C.x() + tf * d.x());
        fy = fixed(C.z() + tf * d.z());
        row0 = floor_row;
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
      xy_row[u] = cv::Vec2s(static_cast<short>(fx / kSub), static_cast<short>(row0 + fy / kSub));
      frac_row[u] = static_cast<uint16_t>((fy % kSub) * kSub + (fx % kSub));
    }
  }
  cv::remap(atlas_, *bgr, map_xy_, map_frac_, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar(200, 190, 180));
  if (scene_.chessboard.present) drawChessboard(view, ray_map, bgr, &depth_);
  owner_.create(view.height, view.width, CV_32S);
  owner_.setTo(-1);
  std::vector<int64_t> footprint(scene_.objects.size());
  for (size_t i = 0; i < scene_.objects.size(); ++i) {
    footprint[i] =
        drawObject(scene_.objects[i], static_cast<int32_t>(i), t_s, view, ray_map, bgr, &depth_);
  }
  if (!visible_fraction) return;
  std::vector<int64_t> shown(scene_.objects.size());
  for (int v = 0; v < owner_.rows; ++v) {
    const int32_t* row = owner_.ptr<int32_t>(v);
    for (int u = 0; u < owner_.cols; ++u) {
      if (row[u] >= 0) ++shown[static_cast<size_t>(row[u])];
    }
  }
  visible_fraction->assign(scene_.objects.size(), 0.0);
  for (size_t i = 0; i < footprint.size(); ++i) {
    if (footprint[i] > 0) (*visible_fraction)[i] = static_cast<double>(shown[i]) / footprint[i];
  }
}

int64_t Renderer::drawObject(const SceneObject& object, int32_t index, double t_s,
                             const CameraView& view, const cv::Mat& ray_map, cv::Mat* bgr,
                             cv::Mat* depth) {
  const Eigen::Vector3d centre = object.trajectory.position(t_s);
  const cv::Rect rect = boundingRect(view, centre, object.boundingRadius());
  if (rect.empty()) return 0;
  int64_t footprint = 0;
  const Eigen::Matrix3d& R = view.rotation_head_camera;
  const Eigen::Vector3d C = view.position_head_m;
  const Eigen::Vector3d oc = C - centre;
  const Eigen::Matrix3d box_to_head = object.rotationHeadObject(t_s);
  const Eigen::Vector3d oc_box = box_to_head.transpose() * oc;
  for (int v = rect.y; v < rect.y + rect.height; ++v) {
    const cv::Vec2f* ray_row = ray_map.ptr<cv::Vec2f>(v);
    cv::Vec3b* out = bgr->ptr<cv::Vec3b>(v);
    float* out_depth = depth->ptr<float>(v);
    int32_t* out_owner = owner_.ptr<int32_t>(v);
    for (int u = rect.x; u < rect.x + rect.width; ++u) {
      const Eigen::Vector3d d = R * Eigen::Vector3d(ray_row[u][0], ray_row[u][1], 1.0);
      double t = -1;
      Eigen::Vector3d normal;
      Eigen::Vector2d surface_m;  // texture coordinates on the surface
      if (object.shape == SceneObject::Shape::kSphere) {
        const double b = oc.dot(d), a = d.squaredNorm();
        const double disc = b * b - a * (oc.squaredNorm() - object.radius_m * object.radius_m);
        if (disc < 0) continue;
        t = (-b - std::sqrt(disc)) / a;
        normal = (oc + t * d) / object.radius_m;
        surface_m = object.radius_m * Eigen::Vector2d(std::atan2(normal.x(), -normal.z()),
                                                      std::asin(std::clamp(normal.y(), -1.0, 1.0)));
      } else {
        const Eigen::Vector3d db = box_to_head.transpose() * d;
        double t_near = -1e30, t_far = 1e30;
        int axis = -1;
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
        Eigen::Vector3d n_box = Eigen::Vector3d::Zero();
        n_box[axis] = db[axis] > 0 ? -1 : 1;
        normal = box_to_head * n_box;
        const Eigen::Vector3d p_box = oc_box + t * db;
        surface_m = {p_box[(axis + 1) % 3], p_box[(axis + 2) % 3]};
      }
      if (t <= 0) continue;
      ++footprint;
      if (t >= out_depth[u]) continue;
      out_depth[u] = static_cast<float>(t);
      out_owner[u] = index;
      out[u] = shade(object.color_bgr, normal);
      if (object.textured) {
        // Four times finer than the backdrop: objects are small, and the texture's coarse
        // scales would only shade them.
        const double texel_m = scene_.texture_m_per_texel / 4;
        const double level = textureLevel(atlas_, surface_m.x() / texel_m, surface_m.y() / texel_m);
        out[u] = out[u] * (0.5 + 0.5 * level);
      }
    }
  }
  return footprint;
}

void Renderer::drawChessboard(const CameraView& view, const cv::Mat& ray_map, cv::Mat* bgr,
                              cv::Mat* depth) {
  const Chessboard& b = scene_.chessboard;
  // The board with a white margin of one square around the (inner + 1) squares.
  const double half_w = (b.inner_cols + 3) * b.square_m / 2;
  const double half_h = (b.inner_rows + 3) * b.square_m / 2;
  const cv::Rect rect = boundingRect(view, b.centre_head_m, std::hypot(half_w, half_h));
  if (rect.empty()) return;
  const Eigen::Matrix3d& R = view.rotation_head_camera;
  const Eigen::Matrix3d Rb = b.rotation_head_board.transpose();
  const Eigen::Vector3d o = Rb * (view.position_head_m - b.centre_head_m);
  // Corner (0,0) of the squares grid sits at -(inner + 1)/2 squares from the centre.
  const double x0 = -(b.inner_cols + 1) * b.square_m / 2, y0 = -(b.inner_rows + 1) * b.square_m / 2;
  constexpr int kSub = 4;  // supersampling so corner positions are sub-pixel exact
  for (int v = rect.y; v < rect.y + rect.height; ++v) {
    cv::Vec3b* out = bgr->ptr<cv::Vec3b>(v);
    float* out_depth = depth->ptr<float>(v);
    for (int u = rect.x; u < rect.x + rect.width; ++u) {
      int hits = 0, white = 0;
      double t_centre = -1;
      // Rays between pixel centres: interpolate the ray map.
      const int u1 = std::min(u + 1, view.width - 1), v1 = std::min(v + 1, view.height - 1);
      const int u0 = std::max(u - 1, 0), v0 = std::max(v - 1, 0);
      const cv::Vec2f& rc = ray_map.at<cv::Vec2f>(v, u);
      const cv::Vec2f gx = (ray_map.at<cv::Vec2f>(v, u1) - ray_map.at<cv::Vec2f>(v, u0)) *
                           (1.0f / static_cast<float>(std::max(1, u1 - u0)));
      const cv::Vec2f gy = (ray_map.at<cv::Vec2f>(v1, u) - ray_map.at<cv::Vec2f>(v0, u)) *
                           (1.0f / static_cast<float>(std::max(1, v1 - v0)));
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

NoiseBank::NoiseBank(int width, int height, double sigma, unsigned seed)
    : sigma_(sigma), seed_(seed) {
  if (sigma <= 0) return;
  cv::RNG rng(seed);
  cv::Mat noise(height + 64, width + 64, CV_32FC3);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, sigma);
  // Positive and negative parts as 8-bit images: two saturating 8-bit passes per frame.
  cv::Mat positive, negative;
  cv::max(noise, 0.0, positive);
  cv::max(-noise, 0.0, negative);
  positive.convertTo(positive_, CV_8U);
  negative.convertTo(negative_, CV_8U);
}

void NoiseBank::apply(uint64_t frame_index, int camera, cv::Mat* bgr) const {
  if (positive_.empty()) return;
  cv::RNG rng(seed_ ^ (frame_index * 2654435761ULL) ^ (static_cast<uint64_t>(camera) << 40));
  const int dx = rng.uniform(0, 64), dy = rng.uniform(0, 64);
  const cv::Rect slice(dx, dy, bgr->cols, bgr->rows);
  cv::add(*bgr, positive_(slice), *bgr);
  cv::subtract(*bgr, negative_(slice), *bgr);
}

}  // namespace ptz::sim
