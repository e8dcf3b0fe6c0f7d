#include "control/controller/search.hpp"

#include <algorithm>
#include <cmath>

#include "control/controller/pointing.hpp"

namespace ptz::control {

Eigen::Vector2d widestFieldOfView(const CameraSpec& spec) {
  const Intrinsics k = spec.intrinsicsAt(spec.minZoom());
  return {2 * std::atan(spec.width / 2.0 / k.fx), 2 * std::atan(spec.height / 2.0 / k.fy)};
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
  waypoints_.clear();
  if (last_seen) waypoints_.push_back(*last_seen);
  const auto sweep =
      searchWaypoints(p_, widestFieldOfView(rig_.left), last_seen ? *last_seen : from);
  waypoints_.insert(waypoints_.end(), sweep.begin(), sweep.end());
  index_ = 0;
  active_ = true;
  arrived_s_.reset();
  last_setpoint_.reset();
  has_last_seen_ = last_seen.has_value();
}

bool Search::aim(Side side, const Eigen::Vector2d& direction, double* pan_rad,
                 double* tilt_rad) const {
  Eigen::Matrix3d R;
  Eigen::Vector3d c;
  rig_.cameraPose(Side::kLeft, direction.x(), direction.y(), &R, &c);
  const Eigen::Vector3d point = c + R * Eigen::Vector3d(0, 0, p_.range_m);
  return aimAt(rig_, side, point, rig_.camera(side).minZoom(), imageCentre(rig_.camera(side)),
               pan_rad, tilt_rad);
}

Eigen::Vector2d Search::direction(double t_s, const Eigen::Vector2d& left_setpoint) {
  if (waypoints_.empty()) return left_setpoint;
  const Eigen::Vector2d w = waypoints_[static_cast<size_t>(index_)];
  Eigen::Vector2d goal = w;
  aim(Side::kLeft, w, &goal.x(), &goal.y());
  // Reached, or as near as the axis limits let the setpoint come (it stopped moving).
  const bool stuck = last_setpoint_ && (left_setpoint - *last_setpoint_).norm() < 1e-9;
  last_setpoint_ = left_setpoint;
  if ((left_setpoint - goal).norm() > 1e-3 && !stuck) return w;
  // Reached: the last seen direction is looked at for dwell_s, a sweep's end passed at once.
  if (index_ == 0 && has_last_seen_) {
    if (!arrived_s_) arrived_s_ = t_s;
    if (t_s - *arrived_s_ < p_.dwell_s) return w;
  }
  const int first_sweep = has_last_seen_ ? 1 : 0;
  ++index_;
  arrived_s_.reset();
  last_setpoint_.reset();
  if (index_ >= static_cast<int>(waypoints_.size())) index_ = first_sweep;
  return waypoints_[static_cast<size_t>(index_)];
}

}  // namespace ptz::control
