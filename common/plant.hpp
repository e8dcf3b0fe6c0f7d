// The PTZ motor model shared by the simulator and the controllers: every axis is a first-order
// lag (gain K, time constant T) behind a dead time tau, with position and rate limits.
#pragma once

#include <array>
#include <deque>
#include <string>

#include "common/rig.hpp"

namespace ptz {

struct AxisParams {
  double gain = 1.0;              // K: steady-state position per unit of setpoint
  double time_constant_s = 0.24;  // T (the paper's motor)
  double dead_time_s = 0.0;       // tau
  double min_position = -1.0;
  double max_position = 1.0;
  double max_rate_per_s = 10.0;  // units of position per second
};

// What became of one setpoint value.
enum class SetpointResult { kAccepted, kClamped, kRejected };

// One axis, integrated exactly for piecewise-constant input (the step is split at every
// moment a delayed setpoint takes effect, so the dead time is exact, not rounded to a step).
class Pt1Axis {
 public:
  Pt1Axis(const AxisParams& params, double initial_position);

  // A setpoint issued at t_s takes effect at t_s + dead_time. Non-finite values are rejected,
  // values outside the position limits are clamped. t_s never goes back in time.
  SetpointResult command(double t_s, double setpoint);
  // Integrates up to t_s with steps no longer than max_step_s.
  void advanceTo(double t_s, double max_step_s);

  double position() const { return position_; }
  double rate() const { return rate_; }
  double time() const { return t_s_; }
  bool atLimit() const;
  const AxisParams& params() const { return params_; }

 private:
  void step(double dt_s);

  AxisParams params_;
  double position_;
  double rate_ = 0.0;
  double input_;
  double t_s_ = 0.0;
  std::deque<std::pair<double, double>> pending_;  // (effective time, setpoint)
};

// Both heads: pan, tilt and zoom of the left and the right camera.
class PtzPlant {
 public:
  enum Axis { kPan = 0, kTilt = 1, kZoom = 2 };
  struct Params {
    std::array<AxisParams, 3> axis;  // pan, tilt, zoom; the same for both heads
    double step_s = 0.0005;          // integration step
  };

  PtzPlant(const Params& params, const PtzPose& left_home, const PtzPose& right_home);

  // Applies a whole setpoint (both heads) issued at t_s. Returns the number of values that
  // were clamped (*clamped) or rejected (*rejected); a rejected value leaves its axis alone.
  void command(double t_s, const PtzPose& left, const PtzPose& right, int* clamped, int* rejected);
  void advanceTo(double t_s);

  PtzPose pose(Side side) const;
  PtzPose rate(Side side) const;
  // Pan or tilt at a position limit.
  bool atLimit(Side side) const;
  const Pt1Axis& axis(Side side, Axis a) const { return axes_[index(side, a)]; }
  double time() const { return axes_[0].time(); }

 private:
  static int index(Side side, Axis a) { return static_cast<int>(side) * 3 + a; }
  Params params_;
  std::array<Pt1Axis, 6> axes_;
};

// Default limits of a typical PTZ head (pan +-170 deg, tilt -30..+90 deg, zoom 1..10x).
PtzPlant::Params defaultPlantParams();

}  // namespace ptz

namespace ptz {
class Params;
// The axis limits alone (<axis>_min, _max, _max_rate for pan, tilt and zoom): what a driver of
// real heads clamps to. Defaults from defaultPlantParams().
void addAxisLimitParams(Params& params);
// The limits and the motor model (<axis>_gain, _time_constant_s, the dead time tau of every
// axis, the integration step): the simulator's plant, a controller's model of it.
void addPlantParams(Params& params);
// The limits; the motor model as in defaultPlantParams().
PtzPlant::Params axisLimitsFrom(const Params& params);
PtzPlant::Params plantParamsFrom(const Params& params);
}  // namespace ptz
