// The pan/tilt/zoom controller of both heads (no LCM). One update per OBJECT_POSE.
//
// Error (paper, eq. 8): e = p_object - p_ref with p_ref on the optical axes through the image
// centres at the reference apparent size. For each camera, aimAt() turns the 3D position into
// the pan/tilt angles theta* that put the object at that camera's image centre (vergence
// follows), and the zoom law turns the range into the zoom that gives it `target_radius_vga_px`.
//
// Modes:
// - "track" (default): u = theta*(t) + omega_hat * lead_s per axis. theta* comes from the 3D
//   position in the head frame, which does not depend on where the cameras point, so with a
//   calibrated rig the loop through the image is open: no steady-state error for a still
//   target, and the feed-forward omega_hat * lead_s (omega_hat: the filtered rate of theta*)
//   cancels the lag of the motor (T) and of the delay for a target moving at constant angular
//   rate. Each axis is then  theta = e^(-s tau) / (1 + T s) * (1 + lead_s s / (1 + Tv s)) theta*.
// - "paper": exactly the paper's loop, a P element on the angular error measured in the image
//   at capture: u = paper_gain * (theta* - theta_capture). With the PT1 axis this is the open
//   loop 1.7 / (1 + 0.24 s) e^(-s tau) with unity feedback (steady-state error 1 / (1 + 1.7)).
// - "smith": for loops with a long delay. A Kalman filter on the 3D position (kf_model: constant
//   velocity, kalman.hpp, or coordinated turn, turn_kalman.hpp) predicts where the target will
//   be when a command issued now acts (after the model's dead time), and a Smith predictor per
//   pan/tilt axis (smith.hpp) steers the plant model's delay-free output onto that prediction,
//   corrected by the measured angle at capture.
//
// A change of the followed track's id starts the target filters afresh (the smith mode's Kalman
// filter, the track mode's filtered rate): a jump to a new target is no outlier of the old one.
//
// Every mode: setpoints slew at most max_setpoint_rate and stay within the limits. Through a loss
// of the target track (it coasts on its prediction) the heads follow the prediction for coast_s
// (coasting); a target whose aim is beyond an axis limit is waited for at the limit (holding,
// limit_wait_s). Then, or without any target lost_hold_s after the start, the heads search
// (search.hpp), or with lost_mode "home" hold and return home at home_rate. A target found again
// is resumed from the current setpoint (slewed, no jump).
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "common/plant.hpp"
#include "common/rig.hpp"
#include "control/controller/search.hpp"
#include "control/prediction/kalman.hpp"
#include "control/prediction/smith.hpp"
#include "control/prediction/turn_kalman.hpp"

namespace ptz::control {

struct ControllerParams {
  std::string mode = "track";  // "track", "paper" or "smith"
  double paper_gain = 1.7;
  std::string zoom_mode = "size";  // "size" (keep target_radius_vga_px) or "hold"
  // In VGA-equivalent px: at another image width the radius scales with it (the same share of
  // the image at every resolution).
  double target_radius_vga_px = 30.0;
  double max_zoom = 4.0;
  // Feed-forward horizon (track): the motor's time constant T plus the capture -> command
  // delay; in lockstep that delay is ~0 plus half a frame of sample-and-hold.
  double lead_s = 0.25;
  double rate_filter_s = 0.25;     // time constant Tv of the rate estimate (track)
  double max_setpoint_rate = 3.0;  // rad/s for pan and tilt; zoom ratio/s for zoom
  double lost_hold_s = 0.5;
  std::string lost_mode = "search";  // "search" or "home"
  double coast_s = 2.0;              // follow a lost target's prediction this long
  double limit_wait_s = 3.0;         // wait this long for a target lost beyond an axis limit
  double limit_margin_rad = 0.02;    // an aim this near a limit counts as at the limit
  SearchParams search;
  double home_rate = 0.3;  // rad/s (pan, tilt) and ratio/s (zoom) when returning home
  double min_range_m = 0.3;
  double max_range_m = 50.0;
  PtzPlant::Params limits = defaultPlantParams();  // smith: also the plant model
  double smith_filter_s = 0.1;        // time constant of the Smith predictor's model-error filter
  double smith_extra_delay_s = 0.0;   // added to the model's dead time (capture -> command)
  double kf_position_sigma_m = 0.01;  // when a pose has no covariance
  std::string kf_model = "ct";        // smith: "cv" (constant velocity) or "ct" (coordinated turn)
  KalmanParams kalman;
  TurnKalmanParams turn_kalman;
};

// The target in one frame: what ptz-detect measured, or its track's prediction.
struct Observation {
  Observation() = default;
  Observation(const Eigen::Vector3d& position, double radius,
              const Eigen::Matrix3d& covariance = Eigen::Matrix3d::Zero())
      : position_head_m(position), radius_m(radius), covariance_m2(covariance) {}

  Eigen::Vector3d position_head_m = Eigen::Vector3d::Zero();
  double radius_m = 0;                                      // <= 0: unknown (zoom holds)
  Eigen::Matrix3d covariance_m2 = Eigen::Matrix3d::Zero();  // zero: unknown
  // From a track: its velocity and acceleration. The track mode's lead then takes the angular
  // rate from the velocity (no filter lag on curves); without them, the filtered angular rate.
  std::optional<Eigen::Vector3d> velocity_m_s;
  Eigen::Vector3d acceleration_m_s2 = Eigen::Vector3d::Zero();
  bool measured = true;   // false: the track coasts, this is its prediction
  int64_t track_id = -1;  // the followed track's id (-1: unknown); a change resets the filters
};

enum class ControlState { kTracking, kCoasting, kSearching, kHolding, kHoming };
const char* controlStateName(ControlState s);

class Controller {
 public:
  Controller(StereoRig rig, ControllerParams params);

  // One step at time t_s (the frame's capture time) with the frame's PTZ at capture and the
  // target if seen. Returns the setpoint of both heads.
  std::array<PtzPose, 2> update(double t_s, const std::optional<Observation>& target,
                                const PtzPose& left_at_capture, const PtzPose& right_at_capture);

  // Whether an observation is usable: finite, in front of both cameras at capture and within
  // range of each; counted by callers.
  bool plausible(const Observation& o, const PtzPose& left_at_capture,
                 const PtzPose& right_at_capture) const;
  const std::array<PtzPose, 2>& setpoint() const { return setpoint_; }
  bool tracking() const { return state_ == ControlState::kTracking; }
  ControlState state() const { return state_; }
  const std::string& reason() const { return reason_; }
  // Seconds since the target was last measured (since the first update when never).
  double sinceTargetS() const { return since_target_s_; }
  const Search& search() const { return search_; }
  // Smith mode: target positions the Kalman filter's gate threw out (wrong detections).
  int64_t outliersRejected() const { return outliers_rejected_; }

 private:
  PtzPose desired(Side side, const Observation& o, const PtzPose& at_capture, double dt);
  // Smith mode: the setpoint for the target predicted by the filter, axis by axis.
  PtzPose desiredSmith(Side side, const Observation& o, const PtzPose& at_capture, double t_s,
                       double dt);
  void observe(double t_s, const Observation& o);
  // The smith mode's target filter (kf_model): its prediction, its reset.
  Eigen::Vector3d predictedAt(double t_s) const;
  bool targetFilterStarted() const;
  void resetTargetFilter();
  // A new followed track id: the target filters start afresh.
  void follows(int64_t track_id);
  double zoomFor(Side side, const Observation& o, const PtzPose& at_capture) const;
  void smithSent(double t_s, const PtzPose& left_at_capture, const PtzPose& right_at_capture);
  void slewTowards(const std::array<PtzPose, 2>& goal, double dt, double rate_angle,
                   double rate_zoom);
  // The goal of both heads for a target (measured or predicted), before slewing and limits.
  std::array<PtzPose, 2> follow(double t_s, const Observation& o, const PtzPose& left_at_capture,
                                const PtzPose& right_at_capture, double dt);
  bool beyondLimits(const std::array<PtzPose, 2>& goal) const;
  // left_at_capture: where the left head was (the search's views wait for it to get there).
  void lost(double t_s, double dt, const PtzPose& left_at_capture);
  void setState(ControlState s, std::string reason);

  StereoRig rig_;
  ControllerParams p_;
  std::array<PtzPose, 2> setpoint_{};
  std::array<PtzPose, 2> last_desired_{};
  std::array<Eigen::Vector2d, 2> rate_{Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  std::optional<double> last_t_s_;
  std::optional<double> last_seen_t_s_;
  std::optional<double> first_t_s_;
  std::optional<Eigen::Vector2d> last_seen_direction_;  // left setpoint (pan, tilt) when measured
  bool tracking_ = false;  // the rate estimate of the track mode is running
  bool lost_at_limit_ = false;
  ControlState state_ = ControlState::kHolding;
  std::string reason_ = "no target yet";
  double since_target_s_ = 0;
  Search search_;
  ConstantVelocityKalman kalman_;
  TurnKalman turn_kalman_;
  std::optional<int64_t> followed_id_;
  int64_t outliers_rejected_ = 0;
  std::array<SmithPredictor, 4> smith_;  // left pan, left tilt, right pan, right tilt
};

}  // namespace ptz::control
