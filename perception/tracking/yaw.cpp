#include "perception/tracking/yaw.hpp"

#include <cmath>

namespace ptz::perception {

double wrapAngle(double d, double period) {
  d = std::fmod(d + period / 2, period);
  if (d < 0) d += period;
  return d - period / 2;
}

Eigen::Vector4d yawQuaternionWxyz(double yaw_rad) {
  return {std::cos(yaw_rad / 2), 0.0, std::sin(yaw_rad / 2), 0.0};
}

}  // namespace ptz::perception
