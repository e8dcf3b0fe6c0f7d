#include "control/prediction/kalman.hpp"

#include <Eigen/Cholesky>

namespace ptz::control {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

ConstantVelocityKalman::ConstantVelocityKalman(KalmanParams params) : p_(params) {}

void ConstantVelocityKalman::start(double t_s, const Eigen::Vector3d& position_m,
                                   const Eigen::Matrix3d& covariance_m2) {
  initialised_ = true;
  rejects_in_row_ = 0;
  t_s_ = t_s;
  x_ << position_m, Eigen::Vector3d::Zero();
  P_.setZero();
  P_.topLeftCorner<3, 3>() = covariance_m2;
  P_.bottomRightCorner<3, 3>() =
      Eigen::Matrix3d::Identity() * p_.initial_speed_sigma_m_s * p_.initial_speed_sigma_m_s;
}

void ConstantVelocityKalman::predictTo(double t_s) {
  const double dt = t_s - t_s_;
  if (dt <= 0) return;
  Matrix6d F = Matrix6d::Identity();
  F.topRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * dt;
  // Discretised white-noise acceleration.
  const double q = p_.accel_psd_m2_s3;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  Matrix6d Q;
  Q << I * q * dt * dt * dt / 3, I * q * dt * dt / 2, I * q * dt * dt / 2, I * q * dt;
  x_ = F * x_;
  P_ = F * P_ * F.transpose() + Q;
  t_s_ = t_s;
}

bool ConstantVelocityKalman::update(double t_s, const Eigen::Vector3d& position_m,
                                    const Eigen::Matrix3d& covariance_m2) {
  if (!initialised_ || t_s < t_s_) {
    start(t_s, position_m, covariance_m2);
    return true;
  }
  predictTo(t_s);
  if (!updatePosition(&x_, &P_, position_m, covariance_m2, p_.gate_chi2)) {
    if (++rejects_in_row_ >= p_.reset_after_rejects) start(t_s, position_m, covariance_m2);
    return false;
  }
  rejects_in_row_ = 0;
  return true;
}

Eigen::Vector3d ConstantVelocityKalman::positionAt(double t_s) const {
  return x_.head<3>() + x_.tail<3>() * (t_s - t_s_);
}

}  // namespace ptz::control
