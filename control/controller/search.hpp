// The search for a target (no LCM): the last seen direction first, then sweeps of the search
// region row by row, the rows spaced so that neighbouring views overlap at the widest field of
// view and the views at the ends just reach the region's edges, the row nearest the current
// tilt first. Directions are the left camera's pan and tilt;
// both cameras converge on the point range_m along it, so what one sees the other sees too.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <vector>

#include "common/rig.hpp"

namespace ptz::control {

struct SearchParams {
  double pan_min_rad = -170 * M_PI / 180, pan_max_rad = 170 * M_PI / 180;
  double tilt_min_rad = -30 * M_PI / 180, tilt_max_rad = 90 * M_PI / 180;
  double overlap = 0.25;    // share of the field of view neighbouring rows have in common
  double range_m = 3.0;     // where the cameras converge while searching
  double dwell_s = 0.5;     // at the last seen direction
  double rate_rad_s = 3.0;  // sweep speed of the pointing direction
};

// Pan and tilt fields of view of a camera at its widest zoom, rad.
Eigen::Vector2d widestFieldOfView(const CameraSpec& spec);

// The sweep's waypoints (pan, tilt): row ends, serpentine, starting at the row nearest `from`'s
// tilt and that row's end nearest `from`'s pan.
std::vector<Eigen::Vector2d> searchWaypoints(const SearchParams& p, const Eigen::Vector2d& fov_rad,
                                             const Eigen::Vector2d& from);

class Search {
 public:
  Search(StereoRig rig, SearchParams params);

  // Starts a search from the left head's current (pan, tilt), first looking at last_seen (a
  // direction) when given.
  void start(const Eigen::Vector2d& from, const std::optional<Eigen::Vector2d>& last_seen);
  bool active() const { return active_; }
  void stop() { active_ = false; }
  // The direction to point at now, given where the left setpoint is (a waypoint reached is passed
  // on; the pattern repeats).
  Eigen::Vector2d direction(double t_s, const Eigen::Vector2d& left_setpoint);
  // Pan and tilt of `side` that look at the point range_m along a direction, at zoom 1.
  bool aim(Side side, const Eigen::Vector2d& direction, double* pan_rad, double* tilt_rad) const;
  int waypoint() const { return index_; }
  int waypoints() const { return static_cast<int>(waypoints_.size()); }
  const SearchParams& params() const { return p_; }

 private:
  StereoRig rig_;
  SearchParams p_;
  bool active_ = false;
  std::vector<Eigen::Vector2d> waypoints_;
  int index_ = 0;
  bool has_last_seen_ = false;  // waypoint 0 is the last seen direction
  std::optional<double> arrived_s_;
  std::optional<Eigen::Vector2d> last_setpoint_;
};

}  // namespace ptz::control
