// Plant identification (beyond the paper): fits the gain K, time constant T and dead time tau of
// one PT1 + dead-time axis to a recorded step test, so a user can check the paper's K and T, and
// the margins they imply, against their own camera.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace ptz::control {

struct AxisRecord {
  std::vector<std::pair<double, double>> setpoints;  // (time issued s, value), in time order
  std::vector<std::pair<double, double>> positions;  // (time measured s, value), in time order
};

struct AxisFit {
  bool ok = false;
  std::string error;  // why not, when !ok
  double gain = 0, time_constant_s = 0, dead_time_s = 0;
  double rms_residual = 0;  // of the measured positions against the fitted model
};

// The model's positions at the record's measurement times for given K, T, tau; the axis starts
// at rest at the first measured position.
std::vector<double> simulateAxis(const AxisRecord& record, double gain, double time_constant_s,
                                 double dead_time_s);

// Least squares (Nelder-Mead, OpenCV's DownhillSolver) from K = 1, T = 0.2 s, tau = 0.05 s.
// Needs a setpoint that changes while positions are recorded.
AxisFit identifyAxis(const AxisRecord& record);

}  // namespace ptz::control
