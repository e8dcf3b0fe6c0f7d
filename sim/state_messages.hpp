// The simulator's state as messages of the contract (no LCM): PTZ_STATE and SIM_TRUTH.
#pragma once

#include <cstdint>

#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "sim/simulator.hpp"

namespace ptz::sim {

ptzstereo::ptz_state_t makeStateMessage(const PtzPlant& plant, int64_t utime);
// The objects' visible fractions come from the frame's render: made before it (at the instant
// of capture), the message gets them from setVisibility once the frame is rendered.
ptzstereo::sim_truth_t makeTruthMessage(const Simulator& sim, const SimFrame& frame, int64_t utime);
void setVisibility(const SimFrame& rendered, ptzstereo::sim_truth_t* truth);

}  // namespace ptz::sim
