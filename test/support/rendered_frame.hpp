// A STEREO_FRAME of a scene rendered by the simulator (cameras at home, raw images), as ptz-sim
// publishes it, for tests that feed a process themselves.
#pragma once

#include "common/transport.hpp"
#include "sim/sim_messages.hpp"
#include "sim/simulator.hpp"

namespace ptz::test {

inline ptzstereo::stereo_frame_t renderedFrame(const ptz::sim::Scene& scene, int64_t seq) {
  ptz::sim::Simulator sim(ptz::StereoRig::makeDefault(), scene, ptz::defaultPlantParams(), 2.0, 1);
  ptzstereo::stereo_frame_t m = ptz::sim::makeFrameMessage(sim.capture(), ptz::wallUtime(),
                                                           ptzstereo::image_t::ENCODING_RAW, 90);
  m.seq = seq;
  return m;
}

}  // namespace ptz::test
