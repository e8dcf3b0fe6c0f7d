#include "sim/render/renderer.hpp"

#include <opencv2/calib3d.hpp>
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

// Undistortion solved every 8 px and interpolated between: within 0.01 px of solving every
// pixel for the default lens, at a sixty-fourth of the cost (zoom changes it every frame).
constexpr int kGridStep = 8;
constexpr int kBandRows = 32;  // rows per band of the parallel render (and of the noise)
constexpr size_t kRayGrids = 4;

// First row of band `band` of `bands` over `rows` rows.
int bandRow(int band, int bands, int rows) {
  return static_cast<int>(static_cast<int64_t>(band) * rows / bands);
}

int autoBands(int rows) {
  return std::max(1, (rows + kBandRows - 1) / kBandRows);
}

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

// The pixels holding the projections of points (camera frame), padded by 2 px and pad_share of
// the larger side, cut to the image; the whole image when a point is not in front of the camera.
cv::Rect projectedRect(const CameraView& view, const std::vector<Eigen::Vector3d>& points_camera,
                       double pad_share) {
  const cv::Rect whole(0, 0, view.width, view.height);
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (const Eigen::Vector3d& q : points_camera) {
    if (q.z() <= 1e-3) return whole;
    const Eigen::Vector2d px = view.projectCamera(q);
    u0 = std::min(u0, px.x());
    v0 = std::min(v0, px.y());
    u1 = std::max(u1, px.x());
    v1 = std::max(v1, px.y());
  }
  const double pad = 2 + pad_share * std::max(u1 - u0, v1 - v0);
  const cv::Point top_left(static_cast<int>(std::floor(std::max(u0 - pad, -1.0))),
                           static_cast<int>(std::floor(std::max(v0 - pad, -1.0))));
  const cv::Point bottom_right(static_cast<int>(std::ceil(std::min(u1 + pad, view.width + 1.0))),
                               static_cast<int>(std::ceil(std::min(v1 + pad, view.height + 1.0))));
  return cv::Rect(top_left, bottom_right) & whole;
}

// Pixel rectangle that holds the image of a sphere of radius r around p (head frame): the
// projections of a slightly larger sphere's surface, padded.
cv::Rect boundingRect(const CameraView& view, const Eigen::Vector3d& p, double r) {
  const Eigen::Vector3d pc = view.toCamera(p);
  if (pc.z() + r <= 0) return {};
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 8; ++i) {
    const double lat = M_PI * i / 8 - M_PI / 2;
    for (int j = 0; j < 16; ++j) {
      const double lon = 2 * M_PI * j / 16;
      points.push_back(pc + 1.25 * r *
                                Eigen::Vector3d(std::cos(lat) * std::cos(lon), std::sin(lat),
                                                std::cos(lat) * std::sin(lon)));
    }
  }
  return projectedRect(view, points, 0.1);
}

// Pixel rectangle that holds the shadow on the floor y = floor_y of a sphere of radius r around
// p (head frame) in the light from to_light (unit, to_light.y() < 0): the shadow lies within the
// circle of radius r / |to_light.y()| around where the ray from p away from the light meets the
// floor; the projections of a polygon around that circle, padded. Empty when all of the sphere is
// under the floor; the whole image when the polygon reaches behind the camera.
cv::Rect shadowRect(const CameraView& view, const Eigen::Vector3d& p, double r,
                    const Eigen::Vector3d& to_light, double floor_y) {
  if (p.y() - r >= floor_y) return {};
  const Eigen::Vector3d foot = p + (floor_y - p.y()) / to_light.y() * to_light;
  constexpr int kSides = 16;
  // Around the circle (the polygon's edges touch a 5 % larger one).
  const double reach_m = 1.05 * r / -to_light.y() / std::cos(M_PI / kSides);
  std::vector<Eigen::Vector3d> points;
  for (int j = 0; j < kSides; ++j) {
    const double a = 2 * M_PI * j / kSides;
    points.push_back(view.toCamera(foot + reach_m * Eigen::Vector3d(std::cos(a), 0, std::sin(a))));
  }
  return projectedRect(view, points, 0.05);
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

const Renderer::RayGrid& Renderer::rayGrid(const CameraView& view) {
  for (const RayGrid& g : grids_) {
    if (g.width == view.width && g.height == view.height &&
        sameIntrinsics(g.intrinsics, view.intrinsics)) {
      return g;
    }
  }
  // A new zoom every frame while zooming: the oldest entry's memory is reused.
  if (grids_.size() < kRayGrids) {
    grids_.emplace_back();
  } else {
    std::rotate(grids_.begin(), grids_.begin() + 1, grids_.end());
  }
  RayGrid& grid = grids_.back();
  grid.width = 0;  // not valid until solved
  const Intrinsics& k = view.intrinsics;
  const int gw = view.width / kGridStep + 2, gh = view.height / kGridStep + 2;
  std::vector<cv::Point2f> distorted;
  distorted.reserve(static_cast<size_t>(gw * gh));
  for (int j = 0; j < gh; ++j) {
    for (int i = 0; i < gw; ++i) distorted.emplace_back(i * kGridStep, j * kGridStep);
  }
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  const cv::Mat distortion(k.distortion, true);
  grid.points.resize(distorted.size());
  // Each point is solved alone: rows of the grid on all threads give the same points.
  cv::parallel_for_(cv::Range(0, gh), [&](const cv::Range& range) {
    const auto first = static_cast<ptrdiff_t>(range.start) * gw;
    const auto last = static_cast<ptrdiff_t>(range.end) * gw;
    const std::vector<cv::Point2f> in(distorted.begin() + first, distorted.begin() + last);
    std::vector<cv::Point2f> out;
    cv::undistortPoints(
        in, out, K, distortion, cv::noArray(), cv::noArray(),
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12));
    std::copy(out.begin(), out.end(), grid.points.begin() + first);
  });
  grid.columns = gw;
  grid.intrinsics = k;
  grid.height = view.height;
  grid.width = view.width;
  return grid;
}

Renderer::RayRows Renderer::interpolateRays(const RayGrid& grid, int row0, int row1,
                                            RayScratch* scratch) {
  const int width = grid.width, gw = grid.columns;
  if (scratch->storage.rows < row1 - row0 || scratch->storage.cols != width) {
    scratch->storage.create(std::max(row1 - row0, scratch->storage.rows), width, CV_32FC2);
  }
  scratch->rays = scratch->storage.rowRange(0, row1 - row0);
  scratch->top.resize(static_cast<size_t>(width));
  scratch->span.resize(static_cast<size_t>(width));
  cv::Point2f* top = scratch->top.data();
  cv::Point2f* span = scratch->span.data();
  const cv::Point2f* g = grid.points.data();
  // Bilinear between the grid's points: along the two grid rows once (top, bottom - top), then
  // one multiply and one add per coordinate for each of the rows between them.
  int row_j = -1;
  for (int v = row0; v < row1; ++v) {
    const int j = v / kGridStep;
    if (j != row_j) {
      for (int u = 0; u < width; ++u) {
        const int i = u / kGridStep;
        const float fu = static_cast<float>(u - i * kGridStep) / kGridStep;
        const cv::Point2f& a = g[j * gw + i];
        const cv::Point2f& b = g[j * gw + i + 1];
        const cv::Point2f& c = g[(j + 1) * gw + i];
        const cv::Point2f& d = g[(j + 1) * gw + i + 1];
        top[u] = a + fu * (b - a);
        span[u] = (c + fu * (d - c)) - top[u];
      }
      row_j = j;
    }
    const float fv = static_cast<float>(v - j * kGridStep) / kGridStep;
    cv::Vec2f* out = scratch->rays.ptr<cv::Vec2f>(v - row0);
    for (int u = 0; u < width; ++u) {
      out[u] = cv::Vec2f(top[u].x + fv * span[u].x, top[u].y + fv * span[u].y);
    }
  }
  return {&scratch->rays, row0};
}

const cv::Mat& Renderer::rays(const CameraView& view) {
  RayScratch scratch;
  interpolateRays(rayGrid(view), 0, view.height, &scratch);
  scratch.rays.copyTo(rays_);
  return rays_;
}

Renderer::BackgroundKey Renderer::backgroundKey(const CameraView& view) const {
  return {view.width,
          view.height,
          view.intrinsics,
          view.rotation_head_camera,
          view.position_head_m,
          scene_.backdrop_distance_m,
          scene_.floor_height_m,
          scene_.texture_m_per_texel,
          scene_.chessboard,
          scene_.posters};
}

bool Renderer::sameBackground(const BackgroundKey& a, const BackgroundKey& b) {
  const Chessboard &ca = a.chessboard, &cb = b.chessboard;
  const bool same_board =
      ca.present == cb.present &&
      (!ca.present ||
       (ca.inner_cols == cb.inner_cols && ca.inner_rows == cb.inner_rows &&
        ca.square_m == cb.square_m && ca.rotation_head_board == cb.rotation_head_board &&
        ca.centre_head_m == cb.centre_head_m));
  return a.width == b.width && a.height == b.height && sameIntrinsics(a.intrinsics, b.intrinsics) &&
         a.rotation_head_camera == b.rotation_head_camera &&
         a.position_head_m == b.position_head_m && a.backdrop_distance_m == b.backdrop_distance_m &&
         a.floor_height_m == b.floor_height_m && a.texture_m_per_texel == b.texture_m_per_texel &&
         same_board && a.posters == b.posters;
}

void Renderer::render(const CameraView& view, double t_s, cv::Mat* bgr,
                      std::vector<double>* visible_fraction) {
  // Solved before the bands, which interpolate the rays they need.
  const RayGrid& grid = rayGrid(view);
  const int rows = view.height, cols = view.width;
  const int bands = std::clamp(bands_ > 0 ? bands_ : autoBands(rows), 1, std::max(1, rows));
  // The background (floor, backdrop, chessboard) does not move: while the view stays it is kept
  // and copied. A view seen twice in a row is likely to stay (a still camera), so its
  // background is kept for the frames after; a moving view's is drawn into the image directly.
  const BackgroundKey key = backgroundKey(view);
  const bool same_view = background_drawn_ && sameBackground(key, background_key_);
  const bool draw_background = !(same_view && background_kept_);
  const bool keep_background = draw_background && same_view;
  cv::Rect board_rect;
  if (draw_background) {
    background_drawn_ = false;
    map_xy_.create(rows, cols, CV_16SC2);
    map_frac_.create(rows, cols, CV_16UC1);
    if (keep_background) background_.create(rows, cols, CV_8UC3);
    background_depth_.create(rows, cols, CV_32F);
    const Chessboard& b = scene_.chessboard;
    if (b.present) {
      // The board with a white margin of one square around the (inner + 1) squares.
      board_rect = boundingRect(
          view, b.centre_head_m,
          std::hypot((b.inner_cols + 3) * b.square_m / 2, (b.inner_rows + 3) * b.square_m / 2));
    }
  }
  depth_.create(rows, cols, CV_32F);
  owner_.create(rows, cols, CV_32S);
  bgr->create(rows, cols, CV_8UC3);
  cv::Mat* background_image = keep_background || !draw_background ? &background_ : bgr;
  const size_t n = scene_.objects.size();
  objects_.resize(n);
  to_light_ = scene_.light.toLightAt(t_s);
  // Shadows only from a light above the horizon (a light at the horizon casts them to infinity).
  const bool shadows = scene_.light.shadows && to_light_.y() < -1e-3;
  for (size_t i = 0; i < n; ++i) {
    const SceneObject& object = scene_.objects[i];
    ObjectFrame& o = objects_[i];
    const Eigen::Vector3d centre = object.trajectory.position(t_s);
    o.centre = centre;
    o.rect = boundingRect(view, centre, object.boundingRadius());
    o.shadow_rect = shadows ? shadowRect(view, centre, object.boundingRadius(), to_light_,
                                         scene_.floor_height_m)
                            : cv::Rect();
    o.oc = view.position_head_m - centre;
    o.box_to_head = object.rotationHeadObject(t_s);
    o.oc_box = o.box_to_head.transpose() * o.oc;
    if (object.shape == SceneObject::Shape::kPerson) {
      // Fine enough for a figure 1000 px tall (a person at 1.5 m through a long zoom).
      o.picture = personPicture(1024, object.stride(t_s), object.color_bgr);
      // Sub-rays only where a pixel may straddle the outline: inside and outside are one colour.
      cv::Mat alpha;
      cv::extractChannel(o.picture, alpha, 3);
      cv::morphologyEx(alpha, o.edge, cv::MORPH_GRADIENT,
                       cv::getStructuringElement(cv::MORPH_RECT,
                                                 cv::Size(2 * kEdgeCells + 1, 2 * kEdgeCells + 1)));
    }
  }
  // The rows any object or its shadow may cover: a still view's bands need no rays outside them.
  int object_row0 = rows, object_row1 = 0;
  for (const ObjectFrame& o : objects_) {
    for (const cv::Rect& r : {o.rect, o.shadow_rect}) {
      if (r.empty()) continue;
      object_row0 = std::min(object_row0, r.y);
      object_row1 = std::max(object_row1, r.y + r.height);
    }
  }
  // Per band, per object: footprint and shown pixels; summed in band order below.
  band_counts_.assign(2 * n * static_cast<size_t>(bands), 0);
  cv::parallel_for_(
      cv::Range(0, bands),
      [&](const cv::Range& range) {
        for (int band = range.start; band < range.end; ++band) {
          const int row0 = bandRow(band, bands, rows), row1 = bandRow(band + 1, bands, rows);
          // The background needs its rows' rays (the chessboard also the rows above and below),
          // the objects those of the rows they may cover.
          const int ray0 = draw_background ? std::max(0, row0 - 1) : std::max(row0, object_row0);
          const int ray1 = draw_background ? std::min(rows, row1 + 1) : std::min(row1, object_row1);
          thread_local RayScratch scratch;
          RayRows rays;
          if (ray0 < ray1) rays = interpolateRays(grid, ray0, ray1, &scratch);
          if (draw_background) {
            drawBackground(view, rays, board_rect, row0, row1, background_image);
          }
          if (background_image != bgr) {
            cv::Mat out = bgr->rowRange(row0, row1);
            background_.rowRange(row0, row1).copyTo(out);
          }
          // Shadows move with the objects and the light: on the image, never the kept background,
          // and under the objects drawn next.
          if (shadows) drawShadows(view, rays, row0, row1, bgr);
          // Objects start from the background's depth and no owner, where they may draw.
          const cv::Rect rows_rect(0, row0, cols, row1 - row0);
          for (const ObjectFrame& o : objects_) {
            const cv::Rect r = o.rect & rows_rect;
            if (r.empty()) continue;
            cv::Mat depth = depth_(r), owner = owner_(r);
            background_depth_(r).copyTo(depth);
            owner.setTo(-1);
          }
          int64_t* counts = &band_counts_[2 * n * static_cast<size_t>(band)];
          for (size_t i = 0; i < n; ++i) {
            counts[2 * i] = drawObject(scene_.objects[i], objects_[i], static_cast<int32_t>(i),
                                       view, rays, row0, row1, bgr);
          }
          if (!visible_fraction) continue;
          // Object i owns pixels inside its rectangle only.
          for (size_t i = 0; i < n; ++i) {
            const cv::Rect r = objects_[i].rect & rows_rect;
            int64_t shown = 0;
            for (int v = r.y; v < r.y + r.height; ++v) {
              const int32_t* row = owner_.ptr<int32_t>(v);
              for (int u = r.x; u < r.x + r.width; ++u) shown += row[u] == static_cast<int32_t>(i);
            }
            counts[2 * i + 1] = shown;
          }
        }
      },
      bands);
  if (draw_background) {
    background_key_ = key;
    background_drawn_ = true;
    background_kept_ = keep_background;
  }
  if (!visible_fraction) return;
  std::vector<int64_t> footprint(n), shown(n);
  for (int band = 0; band < bands; ++band) {
    const int64_t* counts = &band_counts_[2 * n * static_cast<size_t>(band)];
    for (size_t i = 0; i < n; ++i) {
      footprint[i] += counts[2 * i];
      shown[i] += counts[2 * i + 1];
    }
  }
  visible_fraction->assign(n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    if (footprint[i] > 0) (*visible_fraction)[i] = static_cast<double>(shown[i]) / footprint[i];
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
  const cv::Mat positive = positive_(slice), negative = negative_(slice);
  // Per pixel: bands of rows on all threads give the same image.
  const int rows = bgr->rows, bands = autoBands(rows);
  cv::parallel_for_(
      cv::Range(0, bands),
      [&](const cv::Range& range) {
        const int row0 = bandRow(range.start, bands, rows), row1 = bandRow(range.end, bands, rows);
        cv::Mat out = bgr->rowRange(row0, row1);
        cv::add(out, positive.rowRange(row0, row1), out);
        cv::subtract(out, negative.rowRange(row0, row1), out);
      },
      bands);
}

}  // namespace ptz::sim
