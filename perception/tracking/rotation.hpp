// A track's full orientation (tagged objects, no LCM): the rotation head <- object turning at an
// angular velocity that changes as white noise (constant angular velocity), filtered in the
// rotation-vector error (head frame, R = exp(e) R_est) and the angular velocity, a 6 x 6
// covariance; gated by the innovation's Mahalanobis distance; refused several times in a row, it
// starts afresh from the measurement (a wrong lock). A steadily turning object is followed without
// lag, and a noisy one (a tag squarely facing the cameras) smoothed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ptz::perception {

struct RotationFilterParams {
  double accel_psd_rad2_s3 = 2.0;  // the angular acceleration's white noise, per axis
  double initial_rate_sigma_rad_s = 2.0;
  double gate_chi2 = 16.27;  // 3 dof, p = 0.001
  int reset_misses = 3;
};

struct RotationEstimate {
  bool ok = false;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // head <- object, at t_s
  Eigen::Vector3d rate_rad_s = Eigen::Vector3d::Zero();          // head frame
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  double t_s = 0;
  int misses = 0;  // measurements refused in a row

  static constexpr double kMaxExtrapolationS = 0.5;
  // The rotation (turned on for kMaxExtrapolationS at most) and its 3 x 3 covariance (rad^2)
  // predicted to when_s.
  Eigen::Quaterniond rotationAt(double when_s) const;
  Eigen::Matrix3d covarianceAt(double when_s, const RotationFilterParams& p) const;
};

enum class RotationUpdate { kStarted, kAccepted, kRefused, kInvalid };

// The estimate updated at t_s by a measured rotation and its covariance (rad^2, head frame).
RotationUpdate updateRotation(RotationEstimate* e, double t_s, const Eigen::Quaterniond& measured,
                              const Eigen::Matrix3d& covariance_rad2,
                              const RotationFilterParams& p);

}  // namespace ptz::perception
