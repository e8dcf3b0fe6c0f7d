#include "perception/detection/stereo.hpp"

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

double objectRadiusM(const Region& region, const Eigen::Vector3d& position_head_m,
                     const CameraView& view) {
  const double r_px = std::sqrt(region.area_px2 / M_PI);
  return r_px * (position_head_m - view.position_head_m).norm() / view.intrinsics.fx;
}

namespace {

constexpr int kTouchMarginPx = 2;
// A split disc's centre comes from part of its circle: twice a whole region's pixel sigma, and
// more as less of the circle is seen (a third of it: 3.6 times).
double splitSigmaFactor(const Region& r) {
  return r.split() ? 2 * std::max(1.0, 0.6 / std::max(r.arc_fraction, 1e-3)) : 1.0;
}

bool touchesBorder(const cv::Rect& box, const CameraView& view) {
  return box.x <= 0 || box.y <= 0 || box.x + box.width >= view.width ||
         box.y + box.height >= view.height;
}

// How many non-tentative tracks of a class have their predicted disc touching the region's box.
int tracksUnder(const cv::Rect& box, const std::string& class_name,
                const std::vector<Track>& tracks, double t_s, const CameraView& view) {
  int n = 0;
  for (const auto& t : tracks) {
    if (t.state == TrackState::kTentative || t.class_name != class_name) continue;
    const Eigen::Vector3d p = t.positionAt(t_s);
    const Eigen::Vector2d px = view.project(p);
    if (!px.allFinite()) continue;
    const double range = (p - view.position_head_m).norm();
    const double r_px = range > 0 ? view.intrinsics.fx * t.radius_m / range : 0;
    const double dx = std::max({box.x - px.x(), 0.0, px.x() - (box.x + box.width)});
    const double dy = std::max({box.y - px.y(), 0.0, px.y() - (box.y + box.height)});
    if (std::hypot(dx, dy) <= r_px) ++n;
  }
  return n;
}

// A region as the shape it fills: a disc (centroid, half its box's larger side) when it fills
// well under its box, as round things do (pi/4 of it), else the box itself.
struct Extent {
  bool disc = false;
  Eigen::Vector2d centre;
  double radius_px = 0;
  cv::Rect box;
};

Extent extentOf(const Region& r) {
  Extent e;
  e.box = r.bbox;
  const double box_area = static_cast<double>(r.bbox.width) * r.bbox.height;
  e.disc = box_area > 0 && r.area_px2 / box_area < 0.9;
  e.centre = {r.centroid_px.x, r.centroid_px.y};
  e.radius_px = std::max(r.bbox.width, r.bbox.height) / 2.0;
  return e;
}

double distanceToBox(const Eigen::Vector2d& p, const cv::Rect& b) {
  const double dx = std::max({b.x - p.x(), 0.0, p.x() - (b.x + b.width)});
  const double dy = std::max({b.y - p.y(), 0.0, p.y() - (b.y + b.height)});
  return std::hypot(dx, dy);
}

// Whether two regions' shapes come within margin_px of each other.
bool near(const Extent& a, const Extent& b, double margin_px) {
  if (a.disc && b.disc)
    return (a.centre - b.centre).norm() <= a.radius_px + b.radius_px + margin_px;
  if (a.disc) return distanceToBox(a.centre, b.box) <= a.radius_px + margin_px;
  if (b.disc) return distanceToBox(b.centre, a.box) <= b.radius_px + margin_px;
  const cv::Rect grown(a.box.x - static_cast<int>(margin_px), a.box.y - static_cast<int>(margin_px),
                       a.box.width + 2 * static_cast<int>(margin_px),
                       a.box.height + 2 * static_cast<int>(margin_px));
  return (grown & b.box).area() > 0;
}

// Whether a region comes within a margin of another region in the same image: one object may be
// hiding part of the other, so neither centre is the object's.
bool touchesAnother(const std::vector<Region>& regions, size_t index, int margin_px) {
  const Region& r = regions[index];
  const Extent e = extentOf(r);
  for (size_t i = 0; i < regions.size(); ++i) {
    // The discs of one blob touch by nature: their centres are fitted to their own arcs.
    if (r.siblingOf(regions[i])) continue;
    if (i != index && near(e, extentOf(regions[i]), margin_px)) return true;
  }
  return false;
}

// Whether a round region (a ball whole, or a disc split from a blob of them) could be either of
// two tracks: two or more non-tentative tracks of its class predicted within half its radius of
// its centre, one hidden behind the other, unless its size says it is the nearest of them (the
// one in front: its predicted apparent radius is the nearest the region's).
bool discAmbiguous(const std::vector<Region>& regions, size_t index, const std::string& class_name,
                   const std::vector<Track>& tracks, double t_s, const CameraView& view) {
  const Region& disc = regions[index];
  const double radius_px = std::sqrt(disc.area_px2 / M_PI);
  // A track nearer another disc of the same blob is that disc's.
  const auto nearer_sibling = [&](const Eigen::Vector2d& px, double d_px) {
    for (size_t i = 0; i < regions.size(); ++i) {
      const Region& o = regions[i];
      if (i != index && disc.siblingOf(o) &&
          std::hypot(px.x() - o.centroid_px.x, px.y() - o.centroid_px.y) < d_px) {
        return true;
      }
    }
    return false;
  };
  int n = 0;
  double nearest_range_m = INFINITY, nearest_misfit = INFINITY, best_misfit = INFINITY;
  for (const auto& t : tracks) {
    if (t.state == TrackState::kTentative || t.class_name != class_name) continue;
    const Eigen::Vector3d p = t.positionAt(t_s);
    const Eigen::Vector2d px = view.project(p);
    const double d_px =
        px.allFinite() ? std::hypot(px.x() - disc.centroid_px.x, px.y() - disc.centroid_px.y) : 0;
    if (!px.allFinite() || d_px > radius_px / 2 || nearer_sibling(px, d_px)) continue;
    ++n;
    const double range_m = (p - view.position_head_m).norm();
    const double predicted_px = range_m > 0 ? view.intrinsics.fx * t.radius_m / range_m : 0;
    const double misfit =
        predicted_px > 0 ? std::abs(std::log(predicted_px / radius_px)) : INFINITY;
    best_misfit = std::min(best_misfit, misfit);
    if (range_m < nearest_range_m) nearest_range_m = range_m, nearest_misfit = misfit;
  }
  return n >= 2 && !(std::isfinite(nearest_misfit) && nearest_misfit <= best_misfit);
}

// Whether a region's objects are ambiguous: a round region with two tracks at its centre
// (discAmbiguous); else a region whose box two tracks' predicted discs reach (objects merged into
// one region, whose centre is neither's).
bool ambiguous(const std::vector<Region>& regions, size_t index, const std::string& class_name,
               const std::vector<Track>& tracks, double t_s, const CameraView& view) {
  const Region& r = regions[index];
  return r.split() || extentOf(r).disc
             ? discAmbiguous(regions, index, class_name, tracks, t_s, view)
             : tracksUnder(r.bbox, class_name, tracks, t_s, view) >= 2;
}

}  // namespace

std::vector<TrackMeasurement> trackMeasurements(
    const std::vector<StereoObject>& objects, const std::vector<Region>& left,
    const std::vector<Region>& right, const CameraView& left_view, const CameraView& right_view,
    const std::vector<std::string>& class_names, double trusted_area_ratio,
    const std::vector<Track>& tracks, double t_s) {
  const double area_scale = std::pow(left_view.intrinsics.fx / right_view.intrinsics.fx, 2);
  std::vector<TrackMeasurement> out;
  for (size_t i = 0; i < objects.size(); ++i) {
    const StereoObject& o = objects[i];
    const Region& l = left[static_cast<size_t>(o.left)];
    const Region& r = right[static_cast<size_t>(o.right)];
    TrackMeasurement m;
    m.class_name = class_names[static_cast<size_t>(o.class_index)];
    m.position_m = o.position_head_m;
    m.covariance_m2 = o.covariance_m2;
    m.radius_m = objectRadiusM(l, o.position_head_m, left_view);
    m.object_index = static_cast<int>(i);
    const double sigma_factor = std::max(splitSigmaFactor(l), splitSigmaFactor(r));
    m.covariance_m2 *= sigma_factor * sigma_factor;
    const double ratio = l.area_px2 / (r.area_px2 * area_scale);
    if (touchesBorder(l.bbox, left_view) || touchesBorder(r.bbox, right_view)) {
      m.untrusted = "border";
    } else if (touchesAnother(left, static_cast<size_t>(o.left), kTouchMarginPx) ||
               touchesAnother(right, static_cast<size_t>(o.right), kTouchMarginPx)) {
      m.untrusted = "touching";
    } else if (ambiguous(left, static_cast<size_t>(o.left), m.class_name, tracks, t_s, left_view) ||
               ambiguous(right, static_cast<size_t>(o.right), m.class_name, tracks, t_s,
                         right_view)) {
      m.untrusted = "overlap";
    } else if (ratio > trusted_area_ratio || ratio < 1 / trusted_area_ratio) {
      m.untrusted = "lr_area";
    }
    out.push_back(m);
  }
  return out;
}

std::vector<ViewMeasurement> viewMeasurements(
    const std::vector<StereoObject>& objects, const std::vector<Region>& left,
    const std::vector<Region>& right, const CameraView& left_view, const CameraView& right_view,
    const std::vector<std::string>& class_names, double sigma_px, const std::vector<Track>& tracks,
    double t_s) {
  std::vector<ViewMeasurement> out;
  const std::vector<Region>* regions[2] = {&left, &right};
  const CameraView* views[2] = {&left_view, &right_view};
  for (int side = 0; side < 2; ++side) {
    std::vector<bool> paired(regions[side]->size());
    for (const StereoObject& o : objects)
      paired[static_cast<size_t>(side == 0 ? o.left : o.right)] = true;
    for (size_t i = 0; i < regions[side]->size(); ++i) {
      const Region& r = (*regions[side])[i];
      if (paired[i] || r.class_index < 0 ||
          static_cast<size_t>(r.class_index) >= class_names.size()) {
        continue;
      }
      const std::string& class_name = class_names[static_cast<size_t>(r.class_index)];
      if (touchesBorder(r.bbox, *views[side]) ||
          touchesAnother(*regions[side], i, kTouchMarginPx) ||
          ambiguous(*regions[side], i, class_name, tracks, t_s, *views[side])) {
        continue;
      }
      ViewMeasurement m;
      m.class_name = class_name;
      m.side = side == 0 ? Side::kLeft : Side::kRight;
      m.pixel = {r.centroid_px.x, r.centroid_px.y};
      m.sigma_px = sigma_px * splitSigmaFactor(r);
      m.radius_px = std::sqrt(r.area_px2 / M_PI);
      m.region_index = static_cast<int>(i);
      out.push_back(m);
    }
  }
  return out;
}

}  // namespace ptz::perception
