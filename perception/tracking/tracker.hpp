// Tracks with identity (no LCM): every triangulated object of a frame updates the track it belongs
// to, or starts one. Each track is a Kalman filter in the head frame with a constant-acceleration
// model (white jerk), which follows curved paths that a constant-velocity model lags on.
// Association is gated by the Mahalanobis distance with the measurement's own covariance and made
// globally nearest-first within a class, in a cascade: tracks updated within recover_window_s
// first, then sharp turns recovered (below), then tracks longer unseen. Life cycle: tentative ->
// confirmed after confirm_hits measurements; a confirmed track not updated in a frame is coasting
// (its values the prediction) and is deleted after coast_s without being seen; a tentative one
// after tentative_max_gap_s. A coasting track's acceleration fades (coast_accel_decay_s), so its
// prediction goes on straight; a trusted measurement near enough to a coasting track's prediction
// restarts it (a sharp turn). A measurement that is seen but not trusted as the object's centre
// (cut by an image border, areas of the two views out of line, or a radius that jumps against the
// track's) keeps its track alive without moving it.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "perception/tracking/rotation.hpp"

namespace ptz::perception {

struct TrackerParams {
  double jerk_psd_m2_s5 = 5.0;  // q: white jerk, (m/s^3)^2 per Hz, each axis
  double gate_chi2 = 16.27;     // chi-square, 3 dof, p = 0.001
  double initial_speed_sigma_m_s = 2.0;
  double initial_accel_sigma_m_s2 = 4.0;
  double min_position_sigma_m = 0.003;  // added to every measurement's covariance
  int confirm_hits = 3;
  double tentative_max_gap_s = 0.25;
  double coast_s = 2.5;  // longer than the controller's coast_s, so it has a track to follow
  double max_radius_ratio = 1.25;  // trusted radii are within this factor of the track's
  double radius_filter = 0.3;      // weight of a new radius in the track's average
  // While a track coasts its acceleration fades with this time constant: an old turn rate is no
  // guide to where a hidden object goes, and extrapolating it quadratically runs away.
  double coast_accel_decay_s = 0.3;
  // A trusted measurement no gate took, of the track's radius, within recover_speed_m_s times the
  // time since the last update (at most recover_window_s ago; at least the track's radius) of a
  // coasting track's prediction,
  // restarts that track there (same id, velocity unknown): an object that turned sharply (a
  // bounce, a reversal) keeps its identity. 0: off.
  double recover_speed_m_s = 1.5;
  double recover_window_s = 0.5;  // only this soon after the track's last update
  size_t max_tracks = 64;         // live tracks at most; measurements beyond start none (counted)
  // Pairs rank by d2 + ln det S, det S capped at this sigma per axis: past it a track's spread
  // says only that it is lost, and must not outrank a nearer prediction that is merely older.
  double rank_sigma_cap_m = 0.3;
  // Yaw (boxes): a random walk of this power spectral density, rad^2/s, filtered per track;
  // a measured yaw whose innovation^2 over its variance exceeds yaw_gate_chi2 is refused (1 dof,
  // p = 0.001), and yaw_reset_misses refusals in a row start the yaw afresh (a wrong lock).
  double yaw_psd_rad2_s = 0.05;
  double yaw_gate_chi2 = 10.83;
  int yaw_reset_misses = 3;
  // Full orientations (tagged objects): their random walk, gate and reset.
  RotationFilterParams rotation;
  double view_gate_chi2 = 13.82;  // one-view updates: chi-square, 2 dof, p = 0.001
  // One view fixes two directions; the third (depth) comes from the track, so only this soon after
  // its last 3D measurement: a long-coasted depth has drifted (s).
  double view_max_depth_age_s = 0.5;
  // updateLate's measurements older than the newest frame by more than this are dropped (s): a
  // search for new objects that took longer (a loaded machine's, HOG's) says too little of now.
  double late_max_age_s = 0.5;
};

enum class TrackState { kTentative, kConfirmed, kCoasting };
const char* trackStateName(TrackState s);

struct TrackMeasurement {
  std::string class_name;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // head frame
  Eigen::Matrix3d covariance_m2 = Eigen::Matrix3d::Zero();
  double radius_m = 0;    // <= 0: unknown
  std::string untrusted;  // why it is not the object's centre ("" = trusted)
  int object_index = -1;  // into the frame's objects
  // A box's yaw about the head's y axis, its variance, and the period of its symmetry (pi/2 for
  // a square footprint): yaws a period apart are the same.
  bool has_yaw = false;
  double yaw_rad = 0;
  double yaw_var_rad2 = 0;
  double yaw_period_rad = M_PI / 2;
  // A tagged object's whole orientation (head <- object) and its rotation-vector covariance.
  bool has_rotation = false;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Matrix3d rotation_covariance_rad2 = Eigen::Matrix3d::Zero();
};

// A region of one camera that no stereo pair used: the object is hidden in the other view (behind
// a look-alike in front, say). It moves a track that no 3D measurement took this frame, along the
// image directions; the track's depth goes on by its prediction.
struct ViewMeasurement {
  std::string class_name;
  Side side = Side::kLeft;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // distorted image coordinates
  double sigma_px = 0.3;
  double radius_px = 0;   // of a disc of the region's area
  int region_index = -1;  // into that camera's regions
};

struct Track {
  int64_t id = 0;
  std::string class_name;
  TrackState state = TrackState::kTentative;
  Eigen::Matrix<double, 9, 1> x = Eigen::Matrix<double, 9, 1>::Zero();  // p, v, a
  Eigen::Matrix<double, 9, 9> P = Eigen::Matrix<double, 9, 9>::Identity();
  double radius_m = 0;
  double t_s = 0;  // time of x and P
  double first_s = 0, last_update_s = 0, last_seen_s = 0;
  double last_stereo_s = 0;  // its last 3D measurement (last_update_s counts one-view ones too)
  // Born within 4 radii of other tracks of its class seen in the same frame, as in a merge of
  // look-alikes: their ids (none: born apart). Either could be the object the other was.
  std::vector<int64_t> born_beside_ids;
  bool bornBeside(int64_t id) const {
    return std::find(born_beside_ids.begin(), born_beside_ids.end(), id) != born_beside_ids.end();
  }
  int hits = 0;
  int untrusted_updates = 0;
  int object_index = -1;  // the measurement that updated it in the last frame (-1: none)
  // The one-view measurement that updated it in the last frame instead (-1: none), and its camera.
  int view_region_index = -1;
  Side view_side = Side::kLeft;
  // The filtered yaw (boxes; has_yaw false: none yet or a sphere), its variance at yaw_t_s, its
  // period, and the measured yaws refused in a row.
  bool has_yaw = false;
  double yaw_rad = 0;
  double yaw_var_rad2 = 0;
  double yaw_t_s = 0;
  double yaw_period_rad = M_PI / 2;
  int yaw_misses = 0;
  RotationEstimate rotation;  // a tagged object's (rotation.ok false: none)

  Eigen::Vector3d position() const { return x.head<3>(); }
  Eigen::Vector3d velocity() const { return x.segment<3>(3); }
  Eigen::Vector3d acceleration() const { return x.tail<3>(); }
  Eigen::Matrix3d positionCovariance() const { return P.topLeftCorner<3, 3>(); }
  Eigen::Matrix3d velocityCovariance() const { return P.block<3, 3>(3, 3); }
  // Position extrapolated to t_s by the motion model (no state change), and its covariance carried
  // there (p + v dt + a dt^2 / 2; the process noise of a frame or so is left out).
  Eigen::Vector3d positionAt(double t_s) const;
  Eigen::Matrix3d positionCovarianceAt(double t_s) const;
  // The yaw's variance at t_s (the random walk's growth since yaw_t_s).
  double yawVarianceAt(double t_s, double yaw_psd_rad2_s) const;
};

class Tracker {
 public:
  explicit Tracker(TrackerParams params = {});

  // One frame's measurements at capture time t_s. Times that go back start afresh (a restarted
  // source); ids are never reused.
  void update(double t_s, const std::vector<TrackMeasurement>& measurements);
  // After update() at the same t_s: each confirmed track that no measurement touched (not even an
  // untrusted one), measured in 3D within view_max_depth_age_s, is moved by the one region of its
  // class that alone is near its predicted image (2-dof Mahalanobis gate, an apparent radius
  // within max_radius_ratio of its own), which no other such track gates and no other
  // non-tentative track not updated by a measurement of its own overlaps (its predicted disc);
  // and counts as updated (confirmed). views: the frame's cameras.
  void updateFromViews(double t_s, const std::vector<ViewMeasurement>& measurements,
                       const CameraView& left, const CameraView& right);
  // Measurements of a frame update() took already (t_s: its time, the newest or up to
  // late_max_age_s before it) found after its messages were out (ptz-detect's search for new
  // objects, kept off the frames' latency), each moved to the newest frame's time by its track's
  // own motion: one gated by a track seen at t_s or since is dropped (counted known), one gated by
  // a track not seen since updates that track (counted), any other trusted one starts a tentative
  // track at t_s, predicted to the newest time (counted). Of a later or older frame: dropped,
  // counted.
  void updateLate(double t_s, const std::vector<TrackMeasurement>& measurements);
  // updateLate's counts since the start: known, updates, starts, dropped.
  int64_t lateKnown() const { return late_known_; }
  int64_t lateUpdates() const { return late_updates_; }
  int64_t lateStarts() const { return late_starts_; }
  int64_t lateDropped() const { return late_dropped_; }
  // Tracks moved by one view, since the start.
  int64_t viewUpdates() const { return view_updates_; }
  const std::vector<Track>& tracks() const { return tracks_; }
  // Deletes every track of a class (a new click's object is not the old one's).
  void eraseClass(const std::string& class_name);
  const Track* find(int64_t id) const;
  // Measurements not trusted as a centre, by reason, since the start.
  const std::map<std::string, int64_t>& untrustedCounts() const { return untrusted_counts_; }
  // Tracks restarted by a measurement outside their gate (sharp turns), since the start.
  int64_t recoveries() const { return recoveries_; }
  // Measurements that started no track because max_tracks were live, since the start.
  int64_t tracksRefused() const { return tracks_refused_; }
  int64_t tracksStarted() const { return next_id_ - 1; }
  // Measured yaws the yaw filter took and refused (its gate), since the start.
  int64_t yawsAccepted() const { return yaws_accepted_; }
  int64_t yawsRefused() const { return yaws_refused_; }
  // Measured full orientations the filter took and refused, since the start.
  int64_t rotationsAccepted() const { return rotations_accepted_; }
  int64_t rotationsRefused() const { return rotations_refused_; }
  const TrackerParams& params() const { return p_; }

 private:
  void predict(Track* t, double t_s) const;
  // Mahalanobis distance^2 of m from t's prediction (t already predicted to m's time).
  double distance2(const Track& t, const TrackMeasurement& m, double* log_det) const;
  // Whether m's radius is off t's by more than max_radius_ratio (both known).
  bool radiusOutOfLine(const Track& t, const TrackMeasurement& m) const;
  void correct(Track* t, const TrackMeasurement& m);
  // m taken by t at t_s (t predicted to it): corrected unless m or its radius is untrusted
  // (counted); true when corrected.
  bool apply(Track* t, const TrackMeasurement& m, double t_s);
  // The yaw filter's update by m's yaw (at t's time), with the wrap of its period.
  void correctYaw(Track* t, const TrackMeasurement& m);
  // The full orientation's update by m's (tagged objects).
  void correctRotation(Track* t, const TrackMeasurement& m);
  Eigen::Matrix3d measurementCovariance(const TrackMeasurement& m) const;
  void start(double t_s, const TrackMeasurement& m);
  // A track started by m unless m is untrusted or max_tracks are live (each counted).
  bool startIfTrusted(double t_s, const TrackMeasurement& m);
  // The non-tentative track of m's class not taken this frame whose prediction is nearest m
  // within the recovery radius.
  Track* recoverable(double t_s, const TrackMeasurement& m, const std::vector<bool>& taken);
  void restart(Track* t, double t_s, const TrackMeasurement& m);
  void eraseExpired(double t_s);

  TrackerParams p_;
  std::vector<Track> tracks_;
  int64_t next_id_ = 1;
  double last_t_s_ = 0;
  bool started_ = false;
  std::map<std::string, int64_t> untrusted_counts_;
  int64_t recoveries_ = 0;
  int64_t tracks_refused_ = 0;
  int64_t yaws_accepted_ = 0;
  int64_t yaws_refused_ = 0;
  int64_t rotations_accepted_ = 0;
  int64_t rotations_refused_ = 0;
  int64_t view_updates_ = 0;
  int64_t late_known_ = 0, late_updates_ = 0, late_starts_ = 0, late_dropped_ = 0;
};

}  // namespace ptz::perception
