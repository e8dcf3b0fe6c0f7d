// A constant-velocity Kalman filter on the target's 3D position (head frame), for predicting
// where the target will be when a command issued now takes effect (after the loop's delay).
// State [p, v]; white-noise acceleration of spectral density accel_psd per axis.
#pragma once

#include <Eigen/Core>

namespace ptz::control {

struct KalmanParams {
  double accel_psd_m2_s3 = 0.05;  // q: how much the velocity may wander, (m/s^2)^2 per Hz
  double initial_speed_sigma_m_s = 1.0;
  double gate_chi2 = 25.0;      // reject a measurement beyond this Mahalanobis distance^2
  int reset_after_rejects = 5;  // a target that really jumped: start again from it
};

class ConstantVelocityKalman {
 public:
  explicit ConstantVelocityKalman(KalmanParams params = {});

  // Adds the position measured at t_s with its covariance; returns false when it was gated
  // out (an outlier). Times must not go back; a filter that never saw a target starts here.
  bool update(double t_s, const Eigen::Vector3d& position_m, const Eigen::Matrix3d& covariance_m2);
  // Position and velocity extrapolated to t_s (no state change).
  Eigen::Vector3d positionAt(double t_s) const;
  const Eigen::Vector3d velocity() const { return x_.tail<3>(); }
  Eigen::Matrix<double, 6, 6> covariance() const { return P_; }
  bool initialised() const { return initialised_; }
  void reset() { initialised_ = false; }

 private:
  void predictTo(double t_s);
  void start(double t_s, const Eigen::Vector3d& position_m, const Eigen::Matrix3d& covariance_m2);

  KalmanParams p_;
  bool initialised_ = false;
  int rejects_in_row_ = 0;
  double t_s_ = 0;
  Eigen::Matrix<double, 6, 1> x_ = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 6> P_ = Eigen::Matrix<double, 6, 6>::Identity();
};

}  // namespace ptz::control
