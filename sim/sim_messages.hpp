// Conversions from the simulator's state to the message contract (the LCM edge of ptz-sim).
#pragma once

#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "sim/simulator.hpp"

namespace ptz::sim {

ptzstereo::ptz_state_t makeStateMessage(const PtzPlant& plant, int64_t utime);
ptzstereo::stereo_frame_t makeFrameMessage(const SimFrame& frame, int64_t utime, int8_t encoding,
                                           int jpeg_quality);
// The objects' visible fractions come from the frame's render: made before it (at the instant
// of capture), the message gets them from setVisibility once the frame is rendered.
ptzstereo::sim_truth_t makeTruthMessage(const Simulator& sim, const SimFrame& frame, int64_t utime);
void setVisibility(const SimFrame& rendered, ptzstereo::sim_truth_t* truth);

}  // namespace ptz::sim
