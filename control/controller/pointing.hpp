// Inverse kinematics of one camera: the pan and tilt that image a head-frame point at a given
// pixel, and the zoom that gives a focal length. Both use the rig model (with the optical centre
// offset from the pivots), so they hold for any calibrated rig.
#pragma once

#include <Eigen/Core>

#include "common/rig.hpp"

namespace ptz::control {

// The image centre ((W - 1) / 2, (H - 1) / 2): where tracking puts the object.
Eigen::Vector2d imageCentre(const CameraSpec& spec);

// Pan and tilt (rad) at which `side` images p_head at `pixel` with the given zoom; Gauss-Newton
// from the current pose. False when p is not in front of the camera at the solution.
bool aimAt(const StereoRig& rig, Side side, const Eigen::Vector3d& p_head, double zoom,
           const Eigen::Vector2d& pixel, double* pan_rad, double* tilt_rad);

// The zoom ratio whose focal length fx is `fx_px`, clamped to the zoom table's range.
double zoomForFocalLength(const CameraSpec& spec, double fx_px);

}  // namespace ptz::control
