#include "sim/sim_messages.hpp"

#include "common/transport/transport.hpp"

namespace ptz::sim {

ptzstereo::stereo_frame_t makeFrameMessage(const SimFrame& frame, int64_t utime, int8_t encoding,
                                           int jpeg_quality) {
  return makeStereoFrame(utime, frame.index, frame.left, frame.left_pose, frame.right,
                         frame.right_pose, encoding, jpeg_quality);
}

}  // namespace ptz::sim
