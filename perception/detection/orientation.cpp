#include "perception/detection/orientation.hpp"

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "perception/tracking/yaw.hpp"

namespace ptz::perception {
namespace {

constexpr double kPeriod = M_PI / 2;  // a square footprint looks the same turned by 90 degrees
constexpr double kDeg = M_PI / 180;

using Polygon = std::vector<cv::Point2f>;

double polygonArea(const Polygon& p) {
  return p.size() < 3 ? 0.0 : std::abs(cv::contourArea(p));
}

// Width and height of the points' extent (sub-pixel, unlike cv::boundingRect).
cv::Size2d extent(const Polygon& p) {
  float x0 = 1e30f, x1 = -1e30f, y0 = 1e30f, y1 = -1e30f;
  for (const auto& q : p) {
    x0 = std::min(x0, q.x);
    x1 = std::max(x1, q.x);
    y0 = std::min(y0, q.y);
    y1 = std::max(y1, q.y);
  }
  return p.empty() ? cv::Size2d(0, 0) : cv::Size2d(x1 - x0, y1 - y0);
}

cv::Point2d polygonCentroid(const Polygon& p) {
  const cv::Moments m = cv::moments(p);
  if (std::abs(m.m00) < 1e-9) return {0, 0};
  return {m.m10 / m.m00, m.m01 / m.m00};
}

// What the estimate needs of one view, computed once.
struct ViewData {
  const BoxView* v = nullptr;
  Polygon outline;  // convex hull of the region's pixels (their corners), crop coordinates
  double area_px2 = 0;
  double perimeter_px = 0;
  cv::Point2d centroid;
  double width_px = 0, height_px = 0;
};

bool prepare(const BoxView& v, ViewData* d) {
  d->v = &v;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(v.mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  std::vector<cv::Point> pixels;
  for (const auto& c : contours) pixels.insert(pixels.end(), c.begin(), c.end());
  if (pixels.empty()) return false;
  std::vector<cv::Point> hull_px;
  cv::convexHull(pixels, hull_px);
  // The pixels' outer corners: the outline, not the pixel centres, is what a projection gives.
  Polygon corners;
  for (const cv::Point& p : hull_px) {
    for (int k = 0; k < 4; ++k) {
      corners.emplace_back(static_cast<float>(p.x + (k & 1 ? 0.5 : -0.5)),
                           static_cast<float>(p.y + (k & 2 ? 0.5 : -0.5)));
    }
  }
  cv::convexHull(corners, d->outline);
  d->area_px2 = polygonArea(d->outline);
  d->perimeter_px = cv::arcLength(d->outline, true);
  d->centroid = polygonCentroid(d->outline);
  const cv::Size2d box = extent(d->outline);
  d->width_px = box.width;
  d->height_px = box.height;
  return true;
}

struct Model {
  double yaw_rad = 0;
  double a_m = 0, h_m = 0;  // half extents: footprint, height
  std::array<Polygon, 2> outline;
  double cost_px2 = 0;
  bool ok = false;
};

class Fitter {
 public:
  Fitter(const std::array<ViewData, 2>& views, const Eigen::Vector3d& centre, double a0,
         double height_ratio)
      : views_(views), centre_(centre), a0_(a0), height_ratio_(height_ratio) {
    const Eigen::Vector3d mid =
        (views[0].v->view.position_head_m + views[1].v->view.position_head_m) / 2;
    ray_ = (centre - mid).normalized();
  }

  // The regions' centroids triangulate to the middle of the faces seen, in front of the box's
  // centre: the model's centre is moved back along the line of sight by this much.
  void setDepthOffset(double m) { depth_offset_m_ = m; }
  Eigen::Vector3d centre() const { return centre_ + depth_offset_m_ * ray_; }

  std::array<Eigen::Vector3d, 8> corners(double yaw, double a, double h) const {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
    std::array<Eigen::Vector3d, 8> c;
    for (int k = 0; k < 8; ++k) {
      c[k] = centre() + R * Eigen::Vector3d(k & 1 ? a : -a, k & 2 ? h : -h, k & 4 ? a : -a);
    }
    return c;
  }

  bool project(double yaw, double a, double h, int side, Polygon* hull) const {
    const ViewData& d = views_[side];
    Polygon pts;
    for (const auto& p : corners(yaw, a, h)) {
      const Eigen::Vector2d px = d.v->view.project(p);
      if (!px.allFinite()) return false;
      pts.emplace_back(static_cast<float>(px.x() - d.v->origin.x),
                       static_cast<float>(px.y() - d.v->origin.y));
    }
    cv::convexHull(pts, *hull);
    return hull->size() >= 3;
  }

  Model evaluate(double yaw) {
    ++evaluations_;
    Model m;
    m.yaw_rad = yaw;
    double a = a0_, h = a0_;
    // The size that gives the regions' extents at this yaw: with a known height ratio one
    // scale, from the heights (which hardly depend on the yaw), so the widths test the yaw;
    // else the width follows the footprint, the height the box's height.
    for (int round = 0; round < 3; ++round) {
      double wr = 0, hr = 0;
      for (int s = 0; s < 2; ++s) {
        Polygon hull;
        if (!project(yaw, a, h, s, &hull)) return m;
        const cv::Size2d b = extent(hull);
        if (b.width <= 0 || b.height <= 0) return m;
        wr += views_[s].width_px / b.width / 2;
        hr += views_[s].height_px / b.height / 2;
      }
      if (height_ratio_ > 0) {
        h *= hr;
        a = h / height_ratio_;
      } else {
        a *= wr;
        h *= hr;
      }
    }
    m.a_m = a;
    m.h_m = h;
    for (int s = 0; s < 2; ++s) {
      Polygon& hull = m.outline[s];
      if (!project(yaw, a, h, s, &hull)) return m;
      // On the region's centroid: the triangulated centre is the silhouettes' centroids', not
      // the box's, and a shift would otherwise cost more than a turn.
      const cv::Point2d shift = views_[s].centroid - polygonCentroid(hull);
      for (auto& p : hull)
        p += cv::Point2f(static_cast<float>(shift.x), static_cast<float>(shift.y));
      Polygon both;
      const double inter =
          static_cast<double>(cv::intersectConvexConvex(views_[s].outline, hull, both, true));
      m.cost_px2 += polygonArea(hull) + views_[s].area_px2 - 2 * std::max(0.0, inter);
    }
    m.ok = true;
    return m;
  }

  // How well the model's visible faces explain the region's shading: each face is flat-shaded,
  // so the grey levels within each face's projection vary little when the yaw is right and a
  // face boundary falls across a shading step when it is not. Mean squared deviation of the
  // region's pixels from their face's mean, both views.
  double shadingResidual(const Model& m) const {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(m.yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
    const Eigen::Vector3d half(m.a_m, m.h_m, m.a_m);
    double sum = 0;
    double count = 0;
    for (int s = 0; s < 2; ++s) {
      const ViewData& d = views_[s];
      const cv::Mat& g = d.v->gray;
      Polygon hull;
      if (!project(m.yaw_rad, m.a_m, m.h_m, s, &hull)) return 1e30;
      const cv::Point2d shift = d.centroid - polygonCentroid(hull);
      cv::Mat label = cv::Mat::zeros(g.size(), CV_8U);
      int faces = 0;
      for (int axis = 0; axis < 3; ++axis) {
        for (double sign : {-1.0, 1.0}) {
          Eigen::Vector3d n = Eigen::Vector3d::Zero();
          n[axis] = sign;
          const Eigen::Vector3d face_centre = centre() + R * n.cwiseProduct(half);
          if ((d.v->view.position_head_m - face_centre).dot(R * n) <= 0) continue;
          const int u = (axis + 1) % 3, w = (axis + 2) % 3;
          std::vector<cv::Point> quad;
          for (double su : {-1.0, 1.0}) {
            for (double sw : {su, -su}) {
              Eigen::Vector3d q = n.cwiseProduct(half);
              q[u] = su * half[u];
              q[w] = sw * half[w];
              const Eigen::Vector2d px = d.v->view.project(centre() + R * q);
              if (!px.allFinite()) return 1e30;
              // 4 bits of sub-pixel position for fillConvexPoly.
              quad.emplace_back(
                  static_cast<int>(std::lround((px.x() - d.v->origin.x + shift.x) * 16)),
                  static_cast<int>(std::lround((px.y() - d.v->origin.y + shift.y) * 16)));
            }
          }
          cv::fillConvexPoly(label, quad, cv::Scalar(++faces), cv::LINE_8, 4);
        }
      }
      std::array<double, 8> n{}, s1{}, s2{};
      const int stride = std::max(1, std::max(g.cols, g.rows) / 120);
      for (int y = 0; y < g.rows; y += stride) {
        const uchar* gr = g.ptr<uchar>(y);
        const uchar* mr = d.v->mask.ptr<uchar>(y);
        const uchar* lr = label.ptr<uchar>(y);
        for (int x = 0; x < g.cols; x += stride) {
          if (mr[x] == 0 || lr[x] == 0 || lr[x] >= 8) continue;
          n[lr[x]] += 1;
          s1[lr[x]] += gr[x];
          s2[lr[x]] += static_cast<double>(gr[x]) * gr[x];
        }
      }
      for (int k = 1; k < 8; ++k) {
        if (n[k] > 0) sum += s2[k] - s1[k] * s1[k] / n[k];
        count += n[k];
      }
    }
    return count > 0 ? sum / count : 1e30;
  }

  // The minimum near yaw, halving the step down to fine_rad (the wrap is the caller's).
  Model refine(Model best, double step, double fine_rad) {
    while (step > fine_rad) {
      step /= 2;
      for (double dir : {-1.0, 1.0}) {
        const Model m = evaluate(best.yaw_rad + dir * step);
        if (m.ok && m.cost_px2 < best.cost_px2) {
          best = m;
          break;
        }
      }
    }
    return best;
  }

  int evaluations() const { return evaluations_; }

 private:
  const std::array<ViewData, 2>& views_;
  Eigen::Vector3d centre_;
  double a0_;
  double height_ratio_;
  Eigen::Vector3d ray_ = Eigen::Vector3d::UnitZ();
  double depth_offset_m_ = 0;
  int evaluations_ = 0;
};

}  // namespace

bool classHasOrientation(const ColorClass& c) {
  return c.shape != "circle";
}

cv::Rect boxCrop(const cv::Rect& r, const cv::Size& image, int margin_px) {
  return cv::Rect(r.x - margin_px, r.y - margin_px, r.width + 2 * margin_px,
                  r.height + 2 * margin_px) &
         cv::Rect(0, 0, image.width, image.height);
}

bool regionCut(const cv::Rect& r, const cv::Size& image) {
  return r.x <= 0 || r.y <= 0 || r.br().x >= image.width || r.br().y >= image.height;
}

BoxView makeBoxView(const Detector& detector, size_t class_index, const cv::Mat& bgr_crop,
                    const cv::Point& origin, const cv::Rect& region_bbox, const CameraView& view) {
  BoxView v;
  v.origin = origin;
  v.view = view;
  cv::Mat filtered;
  cv::medianBlur(bgr_crop, filtered, detector.params().filter_size_px);
  cv::Mat mask = detector.mask(filtered, class_index);
  // Only this region: other objects of the class in the crop are not the box.
  const cv::Rect keep = (region_bbox - origin) & cv::Rect(0, 0, mask.cols, mask.rows);
  v.mask = cv::Mat::zeros(mask.size(), CV_8U);
  if (!keep.empty()) mask(keep).copyTo(v.mask(keep));
  cv::cvtColor(filtered, v.gray, cv::COLOR_BGR2GRAY);
  return v;
}

BoxYaw estimateBoxYaw(const BoxView& left, const BoxView& right, const Eigen::Vector3d& centre,
                      const OrientationParams& p) {
  BoxYaw out;
  std::array<ViewData, 2> views;
  if (!prepare(left, &views[0]) || !prepare(right, &views[1])) {
    out.why = "empty mask";
    return out;
  }
  if (views[0].area_px2 < p.min_area_px2 || views[1].area_px2 < p.min_area_px2) {
    out.why = "region too small";
    return out;
  }
  const double range_m = (centre - left.view.position_head_m).norm();
  if (!(range_m > 0) || !std::isfinite(range_m)) {
    out.why = "centre at the camera";
    return out;
  }
  // First guess of the half extent: the disc of the left region's area, back to metres.
  const double a0 = std::sqrt(views[0].area_px2 / M_PI) * range_m / left.view.intrinsics.fx;
  Fitter fit(views, centre, a0, p.height_ratio);

  // Coarse pass over one period, then the local minima refined.
  const int n = std::max(8, static_cast<int>(std::lround(90.0 / p.coarse_step_deg)));
  const double step = kPeriod / n;
  std::vector<Model> coarse(static_cast<size_t>(n));
  auto coarsePass = [&] {
    for (int i = 0; i < n; ++i)
      coarse[static_cast<size_t>(i)] = fit.evaluate(-kPeriod / 2 + i * step);
  };
  // First at half the box's half extent behind the triangulated point, then at the offset that
  // fits the best coarse yaw best (the perspective of a box close by depends on it).
  fit.setDepthOffset(0.5 * a0);
  coarsePass();
  {
    size_t best_i = 0;
    for (size_t i = 1; i < coarse.size(); ++i) {
      if (coarse[i].ok && (!coarse[best_i].ok || coarse[i].cost_px2 < coarse[best_i].cost_px2))
        best_i = i;
    }
    double best_offset = 0.5 * a0, best_cost = coarse[best_i].ok ? coarse[best_i].cost_px2 : 1e300;
    for (double k : {0.0, 0.25, 0.75, 1.0, 1.25}) {
      fit.setDepthOffset(k * coarse[best_i].a_m);
      const Model m = fit.evaluate(coarse[best_i].yaw_rad);
      if (m.ok && m.cost_px2 < best_cost) {
        best_cost = m.cost_px2;
        best_offset = k * coarse[best_i].a_m;
      }
    }
    fit.setDepthOffset(best_offset);
    if (std::abs(best_offset - 0.5 * a0) > 1e-9) coarsePass();
  }
  std::vector<size_t> minima;
  for (size_t i = 0; i < coarse.size(); ++i) {
    const Model& prev = coarse[(i + coarse.size() - 1) % coarse.size()];
    const Model& next = coarse[(i + 1) % coarse.size()];
    const Model& m = coarse[i];
    if (m.ok && (!prev.ok || m.cost_px2 <= prev.cost_px2) &&
        (!next.ok || m.cost_px2 < next.cost_px2)) {
      minima.push_back(i);
    }
  }
  if (minima.empty()) {
    out.why = "no minimum (the box does not project)";
    out.evaluations = fit.evaluations();
    return out;
  }
  std::sort(minima.begin(), minima.end(),
            [&](size_t a, size_t b) { return coarse[a].cost_px2 < coarse[b].cost_px2; });
  // The best few minima of the outline; those whose cost is near the best one's (mirror images
  // when the top face is barely seen) decided by the shading.
  const double floor_px2 = p.boundary_noise_px * (views[0].perimeter_px + views[1].perimeter_px);
  Model best = fit.refine(coarse[minima[0]], step, p.fine_step_deg * kDeg);
  double best_shading = -1;
  for (size_t k = 1; k < std::min<size_t>(minima.size(), 3); ++k) {
    const Model other = fit.refine(coarse[minima[k]], step, p.fine_step_deg * kDeg);
    if (!other.ok ||
        other.cost_px2 + floor_px2 > p.mirror_cost_ratio * (best.cost_px2 + floor_px2) ||
        std::abs(wrapAngle(other.yaw_rad - best.yaw_rad, kPeriod)) < 5 * kDeg) {
      continue;
    }
    out.mirror_decided = true;
    if (best_shading < 0) best_shading = fit.shadingResidual(best);
    const double other_shading = fit.shadingResidual(other);
    if (other_shading < best_shading) {
      best = other;
      best_shading = other_shading;
    }
  }
  // Curvature of the cost at the minimum (central differences of a degree).
  const double h = 1.0 * kDeg;
  const Model lo = fit.evaluate(best.yaw_rad - h), hi = fit.evaluate(best.yaw_rad + h);
  out.evaluations = fit.evaluations();
  if (!lo.ok || !hi.ok) {
    out.why = "the box does not project near its minimum";
    return out;
  }
  const double curvature = (lo.cost_px2 - 2 * best.cost_px2 + hi.cost_px2) / (h * h);
  // A parabola through the three: the minimum between the samples.
  double yaw = best.yaw_rad;
  if (curvature > 0) yaw += std::clamp(-(hi.cost_px2 - lo.cost_px2) / (2 * h) / curvature, -h, h);
  // The yaw error whose cost rises by the outlines' boundary noise is one sigma.
  const double noise_px2 = p.boundary_noise_px * (views[0].perimeter_px + views[1].perimeter_px);
  const double min_var = std::pow(p.min_sigma_deg * kDeg, 2);
  double var = curvature > 0 ? 2 * noise_px2 / curvature : std::pow(kPeriod / 4, 2);
  var = std::clamp(var, min_var, std::pow(kPeriod / 4, 2));
  out.ok = true;
  out.yaw_rad = wrapAngle(yaw, kPeriod);
  out.variance_rad2 = var;
  out.cost = best.cost_px2 / (views[0].area_px2 + views[1].area_px2);
  out.half_width_m = best.a_m;
  out.half_height_m = best.h_m;
  return out;
}

}  // namespace ptz::perception
