#include "sim/renderer.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

#include "sim/scene/pictures.hpp"

namespace ptz::sim {
namespace {

constexpr int kTextureSize = 1024;  // a power of two: wrap-around by masking
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

// A matte surface of colour base lit from to_light (unit): an ambient 0.45 and 0.55 direct.
cv::Vec3b shade(const cv::Vec3b& base, const Eigen::Vector3d& normal,
                const Eigen::Vector3d& to_light) {
  const double intensity = 0.45 + 0.55 * std::max(0.0, normal.dot(to_light));
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
    cv::Vec3b* out = bgr->ptr<cv::Vec3b>(v);
    float* out_depth = depth_.ptr<float>(v);
    int32_t* out_owner = owner_.ptr<int32_t>(v);
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
    cv::Vec3b* out = bgr->ptr<cv::Vec3b>(v);
    float* out_depth = depth_.ptr<float>(v);
    int32_t* out_owner = owner_.ptr<int32_t>(v);
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
