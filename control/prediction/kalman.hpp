// A constant-velocity Kalman filter on the target's 3D position (head frame), for predicting
// where the target will be when a command issued now takes effect (after the loop's delay).
// State [p, v]; white-noise acceleration of spectral density accel_psd per axis.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace ptz::control {

// A measurement covariance a filter may use: finite, symmetric, positive definite.
inline bool usableCovariance(const Eigen::Matrix3d& c) {
  if (!c.allFinite() || !(c - c.transpose()).isZero(1e-9 * (1 + c.cwiseAbs().maxCoeff()))) {
    return false;
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(c);
  return ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > 0;
}

// The measurement update of a filter whose state starts with the position (H = [I 0]), in
// Joseph form (stays symmetric and positive definite over hours of updates). A measurement
// beyond gate_chi2 (Mahalanobis^2 of the innovation), or one that would leave the state
// non-finite, changes nothing: returns false.
template <int N>
bool updatePosition(Eigen::Matrix<double, N, 1>* x, Eigen::Matrix<double, N, N>* P,
                    const Eigen::Vector3d& position_m, const Eigen::Matrix3d& covariance_m2,
                    double gate_chi2) {
  const Eigen::Vector3d innovation = position_m - x->template head<3>();
  const Eigen::Matrix3d S = P->template topLeftCorner<3, 3>() + covariance_m2;
  const Eigen::LDLT<Eigen::Matrix3d> S_ldlt(S);
  if (S_ldlt.info() != Eigen::Success || !(S_ldlt.vectorD().minCoeff() > 0)) return false;
  if (!(innovation.dot(S_ldlt.solve(innovation)) <= gate_chi2)) return false;
  // K = P H^T S^-1.
  const Eigen::Matrix<double, N, 3> K =
      S_ldlt.solve(P->template leftCols<3>().transpose()).transpose();
  Eigen::Matrix<double, N, N> IKH = Eigen::Matrix<double, N, N>::Identity();
  IKH.template leftCols<3>() -= K;
  const Eigen::Matrix<double, N, 1> x_new = *x + K * innovation;
  const Eigen::Matrix<double, N, N> P_new =
      IKH * *P * IKH.transpose() + K * covariance_m2 * K.transpose();
  if (!x_new.allFinite() || !P_new.allFinite()) return false;
  *x = x_new;
  *P = P_new;
  return true;
}

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
