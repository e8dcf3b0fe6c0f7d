#include "perception/tracking/rotation.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace ptz::perception {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

Eigen::Quaterniond turn(const Eigen::Vector3d& v) {
  const double a = v.norm();
  return a < 1e-15 ? Eigen::Quaterniond::Identity()
                   : Eigen::Quaterniond(Eigen::AngleAxisd(a, v / a));
}

// The transition over dt and its process noise (white angular acceleration).
void transition(double dt, const RotationFilterParams& p, Matrix6d* F, Matrix6d* Q) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  F->setIdentity();
  F->topRightCorner<3, 3>() = dt * I;
  const double q = p.accel_psd_rad2_s3;
  Q->topLeftCorner<3, 3>() = q * dt * dt * dt / 3 * I;
  Q->topRightCorner<3, 3>() = q * dt * dt / 2 * I;
  Q->bottomLeftCorner<3, 3>() = q * dt * dt / 2 * I;
  Q->bottomRightCorner<3, 3>() = q * dt * I;
}

}  // namespace

Eigen::Quaterniond RotationEstimate::rotationAt(double when_s) const {
  // A coasting object's turn is extrapolated for half a second at most: an old rate is no guide.
  return (turn(rate_rad_s * std::clamp(when_s - t_s, 0.0, kMaxExtrapolationS)) * rotation)
      .normalized();
}

Eigen::Matrix3d RotationEstimate::covarianceAt(double when_s, const RotationFilterParams& p) const {
  Matrix6d F, Q;
  transition(std::max(0.0, when_s - t_s), p, &F, &Q);
  return (F * covariance * F.transpose() + Q).topLeftCorner<3, 3>();
}

RotationUpdate updateRotation(RotationEstimate* e, double t_s, const Eigen::Quaterniond& measured,
                              const Eigen::Matrix3d& covariance_rad2,
                              const RotationFilterParams& p) {
  if (!measured.coeffs().allFinite() || std::abs(measured.norm() - 1) > 1e-3 ||
      !covariance_rad2.allFinite() || covariance_rad2.determinant() <= 0) {
    return RotationUpdate::kInvalid;
  }
  const Eigen::Quaterniond q = measured.normalized();
  if (!e->ok || e->misses >= p.reset_misses) {
    *e = {};
    e->ok = true;
    e->rotation = q;
    e->covariance.topLeftCorner<3, 3>() = covariance_rad2;
    e->covariance.bottomRightCorner<3, 3>() =
        Eigen::Matrix3d::Identity() * p.initial_rate_sigma_rad_s * p.initial_rate_sigma_rad_s;
    e->t_s = t_s;
    return RotationUpdate::kStarted;
  }
  // Predicted to t_s (a time that goes back predicts nothing).
  const double dt = std::max(0.0, t_s - e->t_s);
  Matrix6d F, Q;
  transition(dt, p, &F, &Q);
  const Eigen::Quaterniond predicted = e->rotationAt(t_s);
  const Matrix6d P = F * e->covariance * F.transpose() + Q;
  // The innovation: the rotation from the prediction to the measurement, a head-frame vector.
  const Eigen::AngleAxisd d(q * predicted.conjugate());
  const Eigen::Vector3d innovation = d.angle() * d.axis();
  const Eigen::Matrix3d S = P.topLeftCorner<3, 3>() + covariance_rad2;
  if (innovation.dot(S.ldlt().solve(innovation)) > p.gate_chi2) {
    ++e->misses;
    return RotationUpdate::kRefused;
  }
  const Eigen::Matrix<double, 6, 3> K = P.leftCols<3>() * S.inverse();
  const Eigen::Matrix<double, 6, 1> step = K * innovation;
  e->rotation = (turn(step.head<3>()) * predicted).normalized();
  e->rate_rad_s += step.tail<3>();
  Matrix6d I_KH = Matrix6d::Identity();
  I_KH.leftCols<3>() -= K;
  e->covariance = I_KH * P * I_KH.transpose() + K * covariance_rad2 * K.transpose();
  e->covariance = (e->covariance + e->covariance.transpose()) / 2;
  e->t_s = t_s;
  e->misses = 0;
  return RotationUpdate::kAccepted;
}

}  // namespace ptz::perception
