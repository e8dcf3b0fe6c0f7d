#include "common/plant.hpp"

#include <algorithm>
#include <cmath>

namespace ptz {

Pt1Axis::Pt1Axis(const AxisParams& params, double initial_position)
    : params_(params),
      position_(std::clamp(initial_position, params.min_position, params.max_position)),
      input_(position_ / (params.gain != 0 ? params.gain : 1.0)) {}

SetpointResult Pt1Axis::command(double t_s, double setpoint) {
  if (!std::isfinite(setpoint) || !std::isfinite(t_s)) return SetpointResult::kRejected;
  const double clamped = std::clamp(setpoint, params_.min_position, params_.max_position);
  const double effective = std::max(t_s, t_s_) + params_.dead_time_s;
  // Commands take effect in order; a later issue never overtakes an earlier one.
  while (!pending_.empty() && pending_.back().first > effective) pending_.pop_back();
  pending_.emplace_back(effective, clamped);
  return clamped == setpoint ? SetpointResult::kAccepted : SetpointResult::kClamped;
}

void Pt1Axis::step(double dt) {
  const double alpha = 1.0 - std::exp(-dt / params_.time_constant_s);
  double delta = alpha * (params_.gain * input_ - position_);
  const double max_delta = params_.max_rate_per_s * dt;
  delta = std::clamp(delta, -max_delta, max_delta);
  const double next = std::clamp(position_ + delta, params_.min_position, params_.max_position);
  rate_ = (next - position_) / dt;
  position_ = next;
}

void Pt1Axis::advanceTo(double t_s, double max_step_s) {
  while (t_s_ < t_s) {
    while (!pending_.empty() && pending_.front().first <= t_s_) {
      input_ = pending_.front().second;
      pending_.pop_front();
    }
    double end = std::min(t_s, t_s_ + max_step_s);
    if (!pending_.empty()) end = std::min(end, pending_.front().first);
    const double dt = end - t_s_;
    if (dt > 0) step(dt);
    t_s_ = end;
  }
  while (!pending_.empty() && pending_.front().first <= t_s_) {
    input_ = pending_.front().second;
    pending_.pop_front();
  }
}

bool Pt1Axis::atLimit() const {
  // A PT1 only approaches a limit it is driven to: count the last 0.01 % of the range.
  const double margin = 1e-4 * (params_.max_position - params_.min_position);
  return position_ <= params_.min_position + margin || position_ >= params_.max_position - margin;
}

namespace {
std::array<Pt1Axis, 6> makeAxes(const PtzPlant::Params& p, const PtzPose& l, const PtzPose& r) {
  return {Pt1Axis(p.axis[0], l.pan_rad),  Pt1Axis(p.axis[1], l.tilt_rad),
          Pt1Axis(p.axis[2], l.zoom),     Pt1Axis(p.axis[0], r.pan_rad),
          Pt1Axis(p.axis[1], r.tilt_rad), Pt1Axis(p.axis[2], r.zoom)};
}
}  // namespace

PtzPlant::PtzPlant(const Params& params, const PtzPose& left_home, const PtzPose& right_home)
    : params_(params), axes_(makeAxes(params, left_home, right_home)) {}

void PtzPlant::command(double t_s, const PtzPose& left, const PtzPose& right, int* clamped,
                       int* rejected) {
  *clamped = 0;
  *rejected = 0;
  const std::array<double, 6> values{left.pan_rad,  left.tilt_rad,  left.zoom,
                                     right.pan_rad, right.tilt_rad, right.zoom};
  for (int i = 0; i < 6; ++i) {
    switch (axes_[i].command(t_s, values[i])) {
      case SetpointResult::kClamped:
        ++*clamped;
        break;
      case SetpointResult::kRejected:
        ++*rejected;
        break;
      case SetpointResult::kAccepted:
        break;
    }
  }
}

void PtzPlant::advanceTo(double t_s) {
  for (auto& a : axes_) a.advanceTo(t_s, params_.step_s);
}

PtzPose PtzPlant::pose(Side side) const {
  return {axis(side, kPan).position(), axis(side, kTilt).position(), axis(side, kZoom).position()};
}

PtzPose PtzPlant::rate(Side side) const {
  return {axis(side, kPan).rate(), axis(side, kTilt).rate(), axis(side, kZoom).rate()};
}

bool PtzPlant::atLimit(Side side) const {
  // Zoom at 1x is its lower limit and the normal wide view: only pan and tilt count.
  return axis(side, kPan).atLimit() || axis(side, kTilt).atLimit();
}

PtzPlant::Params defaultPlantParams() {
  constexpr double kDeg = M_PI / 180.0;
  PtzPlant::Params p;
  p.axis[PtzPlant::kPan] = {1.0, 0.24, 0.0, -170 * kDeg, 170 * kDeg, 300 * kDeg};
  p.axis[PtzPlant::kTilt] = {1.0, 0.24, 0.0, -30 * kDeg, 90 * kDeg, 200 * kDeg};
  p.axis[PtzPlant::kZoom] = {1.0, 0.24, 0.0, 1.0, 10.0, 20.0};
  return p;
}

}  // namespace ptz

#include "common/config.hpp"

namespace ptz {
namespace {
const char* const kAxisNames[3] = {"pan", "tilt", "zoom"};
const char* const kAxisUnits[3] = {"rad", "rad", "ratio"};

// Per axis the motor model (when asked for) and then the limits, so --help reads axis by axis.
void addAxisParams(Params& params, bool with_model) {
  const PtzPlant::Params d = defaultPlantParams();
  for (int i = 0; i < 3; ++i) {
    const std::string a = kAxisNames[i];
    const std::string u = kAxisUnits[i];
    if (with_model) {
      params.add(a + "_gain", d.axis[i].gain, "", a + " motor gain K", Range::above(0));
      params.add(a + "_time_constant_s", d.axis[i].time_constant_s, "s",
                 a + " motor time constant T", Range::above(0));
    }
    // Pan and tilt within a turn either way (and a little); a zoom ratio is positive.
    const Range position = i == PtzPlant::kZoom ? Range::above(0) : Range::between(-6.3, 6.3);
    params.add(a + "_min", d.axis[i].min_position, u, a + " lower limit", position);
    params.add(a + "_max", d.axis[i].max_position, u, a + " upper limit", position);
    params.add(a + "_max_rate", d.axis[i].max_rate_per_s, u + "/s", a + " rate limit",
               Range::above(0));
    params.addOrder(a + "_min", a + "_max");
  }
}

}  // namespace

void addAxisLimitParams(Params& params) {
  addAxisParams(params, false);
}

void addPlantParams(Params& params) {
  params.add("dead_time_s", 0.0, "s", "dead time tau of every axis (image processing delay)",
             Range::between(0, 60));
  params.add("plant_step_s", defaultPlantParams().step_s, "s",
             "integration step of the motor model", Range::above(0).andAtMost(1));
  addAxisParams(params, true);
}

// Ranges and orders are the declarations' (checked by Params as each value is read).
PtzPlant::Params axisLimitsFrom(const Params& params) {
  params.checkOrders();  // values set() after parsing
  PtzPlant::Params p = defaultPlantParams();
  for (int i = 0; i < 3; ++i) {
    const std::string a = kAxisNames[i];
    AxisParams& ax = p.axis[i];
    ax.min_position = params.getDouble(a + "_min");
    ax.max_position = params.getDouble(a + "_max");
    ax.max_rate_per_s = params.getDouble(a + "_max_rate");
  }
  return p;
}

PtzPlant::Params plantParamsFrom(const Params& params) {
  PtzPlant::Params p = axisLimitsFrom(params);
  p.step_s = params.getDouble("plant_step_s");
  for (int i = 0; i < 3; ++i) {
    const std::string a = kAxisNames[i];
    AxisParams& ax = p.axis[i];
    ax.gain = params.getDouble(a + "_gain");
    ax.time_constant_s = params.getDouble(a + "_time_constant_s");
    ax.dead_time_s = params.getDouble("dead_time_s");
  }
  return p;
}

}  // namespace ptz
