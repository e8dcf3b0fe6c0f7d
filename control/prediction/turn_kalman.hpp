// A coordinated-turn Kalman filter (extended) on the target's 3D position (head frame), for
// predicting far ahead on curves: the velocity turns at a constant angular velocity w about
// any axis, v' = w x v, so a circle in any plane is extrapolated along the circle, not along
// its tangent (the constant-velocity filter's error 1 s ahead on a 0.6 m circle at 1.5 m/s is
// over 1.5 m). State [p, v, w]; white-noise acceleration (accel_psd) on v for changes of speed,
// a random walk (turn_psd) on w; w = 0 is the constant-velocity model.
#pragma once

#include <Eigen/Core>

namespace ptz::control {

struct TurnKalmanParams {
  double accel_psd_m2_s3 = 0.05;          // q_a: speed changes, (m/s^2)^2 per Hz
  double turn_psd_rad2_s3 = 0.03;         // q_w: how fast w may wander, (rad/s)^2 per s
  double initial_speed_sigma_m_s = 1.0;   // of v when the filter starts (at rest)
  double initial_turn_sigma_rad_s = 2.0;  // of w when the filter starts (straight)
  double max_turn_rad_s = 20.0;           // |w| kept below this (a noisy w at low speed)
  double gate_chi2 = 25.0;                // reject a measurement beyond this Mahalanobis^2
  int reset_after_rejects = 5;            // a target that really jumped: start again from it
};

class TurnKalman {
 public:
  using State = Eigen::Matrix<double, 9, 1>;
  using Covariance = Eigen::Matrix<double, 9, 9>;

  explicit TurnKalman(TurnKalmanParams params = {});

  // As ConstantVelocityKalman::update: false when the position was gated out.
  bool update(double t_s, const Eigen::Vector3d& position_m, const Eigen::Matrix3d& covariance_m2);
  // Position extrapolated along the turn to t_s (no state change).
  Eigen::Vector3d positionAt(double t_s) const;
  Eigen::Vector3d velocity() const { return x_.segment<3>(3); }
  Eigen::Vector3d turnRate() const { return x_.tail<3>(); }
  const Covariance& covariance() const { return P_; }
  bool initialised() const { return initialised_; }
  void reset() { initialised_ = false; }

  // The motion model: the state after dt_s at constant w (exact for uniform circular motion).
  static State propagate(const State& x, double dt_s);

 private:
  void predictTo(double t_s);
  void start(double t_s, const Eigen::Vector3d& position_m, const Eigen::Matrix3d& covariance_m2);

  TurnKalmanParams p_;
  bool initialised_ = false;
  int rejects_in_row_ = 0;
  double t_s_ = 0;
  State x_ = State::Zero();
  Covariance P_ = Covariance::Identity();
};

}  // namespace ptz::control
