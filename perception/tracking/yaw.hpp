// A yaw about the head's y axis (no LCM): the difference of two wrapped into the period of the
// object's symmetry (a box with a square footprint: 90 degrees), and the rotation it makes. The
// tracker filters yaws with it; orientation.hpp estimates them; the messages carry the rotation.
#pragma once

#include <Eigen/Core>

namespace ptz::perception {

// a - b wrapped into [-period/2, period/2).
double wrapAngle(double a_minus_b, double period);

// The rotation head <- box of a yaw about the head's y axis, as (w, x, y, z).
Eigen::Vector4d yawQuaternionWxyz(double yaw_rad);

}  // namespace ptz::perception
