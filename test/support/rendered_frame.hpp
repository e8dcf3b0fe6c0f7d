// A STEREO_FRAME of a scene rendered by the simulator (cameras at home, raw images), as ptz-sim
// publishes it, for tests that feed a process themselves.
#pragma once

#include "common/transport/transport.hpp"
#include "sim/sim_messages.hpp"
#include "sim/simulator.hpp"

namespace ptz::test {

inline ptzstereo::stereo_frame_t renderedFrame(const ptz::sim::Scene& scene, int64_t seq) {
  ptz::sim::Simulator sim(ptz::StereoRig::makeDefault(), scene, ptz::defaultPlantParams(), 2.0, 1);
  ptzstereo::stereo_frame_t m = ptz::sim::makeFrameMessage(sim.capture(), ptz::wallUtime(),
                                                           ptzstereo::image_t::ENCODING_RAW, 90);
  m.seq = seq;
  m.publish_utime = m.utime;
  return m;
}

// A red ball 3 m ahead, 0.2 m right, the cameras at home: rendered once, copies differ in seq
// (their times are stamped when published).
inline ptzstereo::stereo_frame_t ballFrame(int64_t seq) {
  static const ptzstereo::stereo_frame_t rendered = [] {
    ptz::sim::Scene scene;
    ptz::sim::SceneObject ball;
    ball.name = "ball";
    ball.class_name = "red_ball";
    ball.color_bgr = {30, 30, 210};
    ball.trajectory.centre_m = {0.2, 0.0, 3.0};
    scene.objects = {ball};
    return renderedFrame(scene, 0);
  }();
  ptzstereo::stereo_frame_t m = rendered;
  m.seq = seq;
  return m;
}

// Stamps a message as captured and published now (consumers drop stale ones), then publishes it.
template <class Msg>
void publishNow(lcm::LCM& lcm, const std::string& channel, Msg msg) {
  msg.utime = ptz::wallUtime();
  msg.publish_utime = msg.utime;
  lcm.publish(channel, &msg);
}

}  // namespace ptz::test
