// The search for a target (no LCM). First the last seen direction; then sweeps of the search
// region row by row at the widest zoom, the rows spaced so that neighbouring views overlap and
// the views at the ends just reach the region's edges, the row nearest the current tilt first;
// then, for what is too small to see wide, views at increasing zoom (zoom_step times the last,
// up to max_zoom), each level's views sized to its field of view (overlapping by `overlap`),
// tiling the wide field of view around where the search began, nearest that centre first, each
// looked at for view_dwell_s once the setpoint is there; then all again. Directions are the left
// camera's pan and tilt; both cameras converge on the point range_m (times the zoom) along it,
// so what one sees the other sees too.
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
  // Zoomed levels: zoom ratios min_zoom * zoom_step^k up to max_zoom (<= min zoom: none); each
  // zoomed view is looked at this long once the setpoint is there (the heads settle, a track is
  // confirmed).
  double zoom_step = 4.0;
  double max_zoom = 4.0;
  double view_dwell_s = 0.7;
};

// One place the search looks: the left camera's direction (pan, tilt) and the zoom; sweep ends
// are passed at once, views (the last seen direction, zoomed views) looked at for a while.
struct SearchView {
  Eigen::Vector2d direction = Eigen::Vector2d::Zero();
  double zoom = 1;
  bool dwell = false;
  int level = 0;  // 0: the widest zoom
};

// One zoom level of the pattern, for reports: its zoom, how many views (or sweep ends), the
// share of the search region they cover, and the smallest angular size (diameter) a detector
// finding blobs of min_diameter_px sees at that zoom.
struct SearchLevel {
  double zoom = 1;
  int waypoints = 0;
  double region_share = 0;
  double min_angular_size_rad = 0;
};

// Pan and tilt fields of view of a camera at its widest zoom (at `zoom`), rad.
Eigen::Vector2d widestFieldOfView(const CameraSpec& spec);
Eigen::Vector2d fieldOfView(const CameraSpec& spec, double zoom);

// The zoom ratios of the zoomed levels (after the widest one).
std::vector<double> searchZooms(const SearchParams& p, const CameraSpec& spec);

// A zoomed level's views: a grid of directions overlapping by p.overlap at its field of view
// fov_rad, covering the field field_rad (pan, tilt extents) around centre, within the search
// region, nearest the centre first.
std::vector<Eigen::Vector2d> zoomedViews(const SearchParams& p, const Eigen::Vector2d& fov_rad,
                                         const Eigen::Vector2d& field_rad,
                                         const Eigen::Vector2d& centre);

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
  // The view to look at now, given where the left setpoint is and where the left head was at the
  // last capture (a waypoint the setpoint reached is passed on; a view is looked at for its dwell
  // from when the head got there, or kMaxWaitS after the setpoint did; the pattern repeats).
  SearchView view(double t_s, const PtzPose& left_setpoint, const PtzPose& left_measured);
  static constexpr double kMaxWaitS = 2.0;
  // Pan and tilt of `side` that look at the point range_m * zoom along a direction at that zoom.
  bool aim(Side side, const SearchView& view, double* pan_rad, double* tilt_rad) const;
  int waypoint() const { return index_; }
  int waypoints() const { return static_cast<int>(waypoints_.size()); }
  // The level of the waypoint now (0: the widest zoom).
  int level() const;
  const SearchParams& params() const { return p_; }
  // The pattern's levels as a search from home would make them; a blob is found from
  // min_diameter_px across.
  std::vector<SearchLevel> levels(double min_diameter_px) const;

 private:
  StereoRig rig_;
  SearchParams p_;
  bool active_ = false;
  std::vector<SearchView> waypoints_;
  int index_ = 0;
  bool has_last_seen_ = false;       // waypoint 0 is the last seen direction
  std::optional<double> arrived_s_;  // the head at the view (its dwell counts from here)
  std::optional<double> setpoint_there_s_;
  std::optional<PtzPose> last_setpoint_;
};

}  // namespace ptz::control
