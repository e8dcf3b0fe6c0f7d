#include "control/prediction/turn_kalman.hpp"

#include "control/prediction/kalman.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

namespace ptz::control {
namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

}  // namespace

TurnKalman::TurnKalman(TurnKalmanParams params) : p_(params) {}

TurnKalman::State TurnKalman::propagate(const State& x, double dt_s) {
  const Eigen::Vector3d p = x.head<3>(), v = x.segment<3>(3), w = x.tail<3>();
  const double n = w.norm(), dt = dt_s, th = n * dt;
  // R = exp(W dt) = I + s1 W + c1 W^2 and its integral A = dt I + c1 W + c2 W^2 (Rodrigues);
  // the series near w = 0, where the closed forms cancel.
  double s1, c1, c2;
  if (std::abs(th) < 1e-3) {
    const double n2 = n * n, dt2 = dt * dt;
    s1 = dt * (1 - n2 * dt2 / 6);
    c1 = dt2 * (0.5 - n2 * dt2 / 24);
    c2 = dt2 * dt * (1.0 / 6 - n2 * dt2 / 120);
  } else {
    s1 = std::sin(th) / n;
    c1 = (1 - std::cos(th)) / (n * n);
    c2 = (dt - std::sin(th) / n) / (n * n);
  }
  const Eigen::Matrix3d W = skew(w), W2 = W * W, I = Eigen::Matrix3d::Identity();
  State out;
  out << p + (dt * I + c1 * W + c2 * W2) * v, (I + s1 * W + c1 * W2) * v, w;
  return out;
}

void TurnKalman::start(double t_s, const Eigen::Vector3d& position_m,
                       const Eigen::Matrix3d& covariance_m2) {
  initialised_ = true;
  rejects_in_row_ = 0;
  t_s_ = t_s;
  x_.setZero();
  x_.head<3>() = position_m;
  P_.setZero();
  P_.topLeftCorner<3, 3>() = covariance_m2;
  const double sv = p_.initial_speed_sigma_m_s, sw = p_.initial_turn_sigma_rad_s;
  P_.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * sv * sv;
  P_.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * sw * sw;
}

void TurnKalman::predictTo(double t_s) {
  const double dt = t_s - t_s_;
  if (dt <= 0) return;
  // The Jacobian by central differences: nine small evaluations, exact enough for the EKF.
  Covariance F;
  for (int j = 0; j < 9; ++j) {
    const double h = 1e-6 * std::max(1.0, std::abs(x_[j]));
    State a = x_, b = x_;
    a[j] += h;
    b[j] -= h;
    F.col(j) = (propagate(a, dt) - propagate(b, dt)) / (2 * h);
  }
  const double q = p_.accel_psd_m2_s3;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  Covariance Q = Covariance::Zero();
  Q.topLeftCorner<3, 3>() = I * q * dt * dt * dt / 3;
  Q.block<3, 3>(0, 3) = Q.block<3, 3>(3, 0) = I * q * dt * dt / 2;
  Q.block<3, 3>(3, 3) = I * q * dt;
  Q.bottomRightCorner<3, 3>() = I * p_.turn_psd_rad2_s3 * dt;
  x_ = propagate(x_, dt);
  P_ = F * P_ * F.transpose() + Q;
  t_s_ = t_s;
}

bool TurnKalman::update(double t_s, const Eigen::Vector3d& position_m,
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
  const double n = x_.tail<3>().norm();
  if (n > p_.max_turn_rad_s) x_.tail<3>() *= p_.max_turn_rad_s / n;
  return true;
}

Eigen::Vector3d TurnKalman::positionAt(double t_s) const {
  return propagate(x_, t_s - t_s_).head<3>();
}

}  // namespace ptz::control
