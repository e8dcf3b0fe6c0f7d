// A rendered frame as STEREO_FRAME (the LCM edge of ptz-sim: image encoding is the transport's).
#pragma once

#include <cstdint>

#include "ptzstereo/stereo_frame_t.hpp"
#include "sim/simulator.hpp"

namespace ptz::sim {

ptzstereo::stereo_frame_t makeFrameMessage(const SimFrame& frame, int64_t utime, int8_t encoding,
                                           int jpeg_quality);

}  // namespace ptz::sim
