// A logged step test of one axis, without the log: the axis by its name, its record from the
// PTZ_STATE and PTZ_SETPOINT messages, and what ptz-identify prints of the fit.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "control/identify/identify.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"

namespace ptz::control {

struct AxisName {
  bool left = true;
  std::string what;  // pan, tilt or zoom
};
// left_pan, left_tilt, left_zoom, right_pan, right_tilt or right_zoom; none for anything else.
std::optional<AxisName> parseAxisName(const std::string& name);

struct StepTest {
  AxisRecord record;
  bool lockstep = false;  // the states carry sim time (a lockstep run)
};
// Positions at the states' utime. A setpoint acts from when it was issued: in lockstep (states
// stamped in sim time, far from the wall clock they were published at) at the frame time it
// names, in real time when it was published.
StepTest stepTestOf(const std::vector<ptzstereo::ptz_state_t>& states,
                    const std::vector<ptzstereo::ptz_setpoint_t>& setpoints, const AxisName& axis);

// K, T, tau of the fit and the margins they give the paper's loop with a P element of paper_gain.
std::string fitReport(const std::string& axis_name, const StepTest& test, const AxisFit& fit,
                      double paper_gain);

}  // namespace ptz::control
