#include "control/controller/search.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "control/controller/pointing.hpp"

namespace ptz::control {
namespace {

constexpr size_t kMaxZoomLevels = 8;
// The head is at a view when within this share of its field of view (and of its zoom).
constexpr double kNearShare = 0.1;

}  // namespace

Eigen::Vector2d fieldOfView(const CameraSpec& spec, double zoom) {
  const Intrinsics k = spec.intrinsicsAt(zoom);
  return {2 * std::atan(spec.width / 2.0 / k.fx), 2 * std::atan(spec.height / 2.0 / k.fy)};
}

Eigen::Vector2d widestFieldOfView(const CameraSpec& spec) {
  return fieldOfView(spec, spec.minZoom());
}

std::vector<double> searchZooms(const SearchParams& p, const CameraSpec& spec) {
  std::vector<double> zooms;
  const double top = std::min(p.max_zoom, spec.maxZoom());
  if (!(p.zoom_step > 1) || !(top > spec.minZoom())) return zooms;
  for (double z = spec.minZoom() * p.zoom_step;
       z < top * (1 - 1e-9) && zooms.size() < kMaxZoomLevels; z *= p.zoom_step) {
    zooms.push_back(z);
  }
  // The top zoom too, unless the last level is near it already.
  if (zooms.empty() || zooms.back() < top / std::sqrt(p.zoom_step)) zooms.push_back(top);
  return zooms;
}

std::vector<Eigen::Vector2d> zoomedViews(const SearchParams& p, const Eigen::Vector2d& fov_rad,
                                         const Eigen::Vector2d& field_rad,
                                         const Eigen::Vector2d& centre) {
  // n views of width fov, spaced at most fov (1 - overlap), spanning the field.
  std::array<std::vector<double>, 2> axes;
  const double lows[2] = {p.pan_min_rad, p.tilt_min_rad},
               highs[2] = {p.pan_max_rad, p.tilt_max_rad};
  for (int a = 0; a < 2; ++a) {
    const double step = std::max(fov_rad[a] * (1 - p.overlap), 1e-3);
    // The field within the region (shifted in from an edge, narrowed where the region is).
    const double field = std::min(field_rad[a], highs[a] - lows[a] + fov_rad[a]);
    const double span = std::max(field - fov_rad[a], 0.0);
    const double mid = std::clamp(centre[a], lows[a] + span / 2,
                                  std::max(lows[a] + span / 2, highs[a] - span / 2));
    const int n = static_cast<int>(std::ceil(span / step - 1e-9)) + 1;
    for (int i = 0; i < n; ++i) {
      const double offset = n > 1 ? -span / 2 + span * i / (n - 1) : 0.0;
      axes[static_cast<size_t>(a)].push_back(std::clamp(mid + offset, lows[a], highs[a]));
    }
  }
  std::vector<Eigen::Vector2d> views;
  for (double tilt : axes[1]) {
    for (double pan : axes[0]) views.emplace_back(pan, tilt);
  }
  std::stable_sort(views.begin(), views.end(), [&](const auto& a, const auto& b) {
    return (a - centre).norm() < (b - centre).norm();
  });
  return views;
}

std::vector<Eigen::Vector2d> searchWaypoints(const SearchParams& p, const Eigen::Vector2d& fov_rad,
                                             const Eigen::Vector2d& from) {
  // Rows no farther apart than the overlapping field of view, their views reaching the region's
  // edges: n rows centred in n equal bands of the tilt region.
  const double step = std::max(fov_rad.y() * (1 - p.overlap), 1e-3);
  const double span = p.tilt_max_rad - p.tilt_min_rad;
  const int rows = std::max(1, static_cast<int>(std::ceil(span / step - 1e-9)));
  std::vector<double> tilts;
  for (int r = 0; r < rows; ++r) tilts.push_back(p.tilt_min_rad + span * (r + 0.5) / rows);
  // The row nearest the current tilt first, then outwards by distance.
  std::stable_sort(tilts.begin(), tilts.end(), [&](double a, double b) {
    return std::abs(a - from.y()) < std::abs(b - from.y());
  });
  // A sweep's ends inset so that the views there just reach the region's pan edges.
  const double inset =
      std::min(fov_rad.x() / 2 * (1 - p.overlap), (p.pan_max_rad - p.pan_min_rad) / 2);
  const double pan_low = p.pan_min_rad + inset, pan_high = p.pan_max_rad - inset;
  std::vector<Eigen::Vector2d> out;
  // The first sweep starts at the end nearest the current pan; each next one where the last
  // ended (serpentine).
  double pan_start =
      std::abs(from.x() - pan_low) <= std::abs(from.x() - pan_high) ? pan_low : pan_high;
  for (double tilt : tilts) {
    const double pan_end = pan_start == pan_low ? pan_high : pan_low;
    out.emplace_back(pan_start, tilt);
    out.emplace_back(pan_end, tilt);
    pan_start = pan_end;
  }
  return out;
}

Search::Search(StereoRig rig, SearchParams params) : rig_(std::move(rig)), p_(params) {}

void Search::start(const Eigen::Vector2d& from, const std::optional<Eigen::Vector2d>& last_seen) {
  const double wide = rig_.left.minZoom();
  waypoints_.clear();
  if (last_seen) waypoints_.push_back({*last_seen, wide, true, 0});
  const Eigen::Vector2d centre = last_seen ? *last_seen : from;
  const Eigen::Vector2d wide_fov = widestFieldOfView(rig_.left);
  for (const auto& w : searchWaypoints(p_, wide_fov, centre)) {
    waypoints_.push_back({w, wide, false, 0});
  }
  const std::vector<double> zooms = searchZooms(p_, rig_.left);
  for (size_t k = 0; k < zooms.size(); ++k) {
    for (const auto& v : zoomedViews(p_, fieldOfView(rig_.left, zooms[k]), wide_fov, centre)) {
      waypoints_.push_back({v, zooms[k], true, static_cast<int>(k) + 1});
    }
  }
  index_ = 0;
  active_ = true;
  arrived_s_.reset();
  setpoint_there_s_.reset();
  last_setpoint_.reset();
  has_last_seen_ = last_seen.has_value();
}

int Search::level() const {
  return waypoints_.empty() ? 0 : waypoints_[static_cast<size_t>(index_)].level;
}

std::vector<SearchLevel> Search::levels(double min_diameter_px) const {
  const Eigen::Vector2d wide_fov = widestFieldOfView(rig_.left);
  const double region = (p_.pan_max_rad - p_.pan_min_rad) * (p_.tilt_max_rad - p_.tilt_min_rad);
  const auto smallest = [&](double zoom) {
    return min_diameter_px / rig_.left.intrinsicsAt(zoom).fx;
  };
  std::vector<SearchLevel> out;
  const double wide = rig_.left.minZoom();
  out.push_back(
      {wide, static_cast<int>(searchWaypoints(p_, wide_fov, {0, 0}).size()), 1.0, smallest(wide)});
  for (double z : searchZooms(p_, rig_.left)) {
    const auto views = zoomedViews(p_, fieldOfView(rig_.left, z), wide_fov, {0, 0});
    const double field = std::min(wide_fov.x(), p_.pan_max_rad - p_.pan_min_rad) *
                         std::min(wide_fov.y(), p_.tilt_max_rad - p_.tilt_min_rad);
    out.push_back(
        {z, static_cast<int>(views.size()), region > 0 ? field / region : 0.0, smallest(z)});
  }
  return out;
}

bool Search::aim(Side side, const SearchView& view, double* pan_rad, double* tilt_rad) const {
  Eigen::Matrix3d R;
  Eigen::Vector3d c;
  rig_.cameraPose(Side::kLeft, view.direction.x(), view.direction.y(), &R, &c);
  // Zoomed in, the search looks for what is far: the cameras converge farther out.
  const double range_m = p_.range_m * std::max(1.0, view.zoom / rig_.left.minZoom());
  const Eigen::Vector3d point = c + R * Eigen::Vector3d(0, 0, range_m);
  return aimAt(rig_, side, point, view.zoom, imageCentre(rig_.camera(side)), pan_rad, tilt_rad);
}

SearchView Search::view(double t_s, const PtzPose& left_setpoint, const PtzPose& left_measured) {
  const Eigen::Vector2d setpoint(left_setpoint.pan_rad, left_setpoint.tilt_rad);
  if (waypoints_.empty()) return {setpoint, left_setpoint.zoom, false, 0};
  const SearchView& w = waypoints_[static_cast<size_t>(index_)];
  Eigen::Vector2d goal = w.direction;
  aim(Side::kLeft, w, &goal.x(), &goal.y());
  // Reached, or as near as the axis limits let the setpoint come (it stopped moving).
  const bool stuck =
      last_setpoint_ &&
      (setpoint - Eigen::Vector2d(last_setpoint_->pan_rad, last_setpoint_->tilt_rad)).norm() <
          1e-9 &&
      std::abs(left_setpoint.zoom - last_setpoint_->zoom) < 1e-9;
  last_setpoint_ = left_setpoint;
  const bool there =
      (setpoint - goal).norm() <= 1e-3 && std::abs(left_setpoint.zoom - w.zoom) <= 1e-3;
  if (!there && !stuck) return w;
  // Reached: a view is looked at for its dwell (the last seen direction for dwell_s) from when the
  // head is there too (a zoom lens may take a second or two), a sweep's end passed at once.
  if (w.dwell) {
    if (!setpoint_there_s_) setpoint_there_s_ = t_s;
    const Eigen::Vector2d fov = fieldOfView(rig_.left, w.zoom);
    const bool head_there = std::abs(left_measured.pan_rad - goal.x()) <= kNearShare * fov.x() &&
                            std::abs(left_measured.tilt_rad - goal.y()) <= kNearShare * fov.y() &&
                            std::abs(left_measured.zoom - w.zoom) <= kNearShare * w.zoom;
    if (!arrived_s_ && (head_there || t_s - *setpoint_there_s_ >= kMaxWaitS)) arrived_s_ = t_s;
    const double dwell_s = index_ == 0 && has_last_seen_ ? p_.dwell_s : p_.view_dwell_s;
    if (!arrived_s_ || t_s - *arrived_s_ < dwell_s) return w;
  }
  const int first_sweep = has_last_seen_ ? 1 : 0;
  ++index_;
  arrived_s_.reset();
  setpoint_there_s_.reset();
  last_setpoint_.reset();
  if (index_ >= static_cast<int>(waypoints_.size())) index_ = first_sweep;
  return waypoints_[static_cast<size_t>(index_)];
}

}  // namespace ptz::control
