#include "control/controller/pointing.hpp"

#include <Eigen/Dense>

#include <cmath>

namespace ptz::control {

Eigen::Vector2d imageCentre(const CameraSpec& spec) {
  return {(spec.width - 1) / 2.0, (spec.height - 1) / 2.0};
}

bool aimAt(const StereoRig& rig, Side side, const Eigen::Vector3d& p, double zoom,
           const Eigen::Vector2d& pixel, double* pan_rad, double* tilt_rad) {
  if (!p.allFinite()) return false;
  // Start from the direction of p seen from the pivot region (pan about y, tilt about x).
  Eigen::Matrix3d R_home;
  Eigen::Vector3d c_home;
  rig.cameraPose(side, 0, 0, &R_home, &c_home);
  const Eigen::Vector3d d = R_home.transpose() * (p - c_home);
  Eigen::Vector2d x(std::atan2(d.x(), d.z()), std::atan2(-d.y(), std::hypot(d.x(), d.z())));
  auto residual = [&](const Eigen::Vector2d& pt) {
    return Eigen::Vector2d(rig.view(side, {pt[0], pt[1], zoom}).project(p) - pixel);
  };
  for (int iter = 0; iter < 10; ++iter) {
    const Eigen::Vector2d r = residual(x);
    if (!r.allFinite()) return false;
    if (r.norm() < 1e-6) break;
    Eigen::Matrix2d J;
    constexpr double h = 1e-6;
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d xh = x;
      xh[k] += h;
      J.col(k) = (residual(xh) - r) / h;
    }
    x -= J.colPivHouseholderQr().solve(r);
  }
  if (!residual(x).allFinite() || residual(x).norm() > 1e-3) return false;
  *pan_rad = x[0];
  *tilt_rad = x[1];
  return true;
}

double zoomForFocalLength(const CameraSpec& spec, double fx_px) {
  double lo = spec.minZoom(), hi = spec.maxZoom();
  if (!(fx_px > spec.intrinsicsAt(lo).fx)) return lo;
  if (!(fx_px < spec.intrinsicsAt(hi).fx)) return hi;
  for (int i = 0; i < 60; ++i) {  // fx grows with zoom along the table
    const double mid = (lo + hi) / 2;
    (spec.intrinsicsAt(mid).fx < fx_px ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}

}  // namespace ptz::control
