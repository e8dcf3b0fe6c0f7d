// The closed loop as separate processes over real LCM, in lockstep: ptz-detect and ptz-control
// started, then ptz-sim run to its end, with everything a run's numbers need recorded.
#pragma once

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/transport/transport.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "tools/logs/run_metrics.hpp"

namespace ptz::test {

inline const std::string kConfig = PTZ_SOURCE_DIR "/config/";

// Listens to everything a run's numbers need.
struct Listener {
  ptz::tools::RunMetrics metrics;
  std::map<std::string, std::map<std::string, int64_t>> counters;  // process -> counter
  std::map<std::string, std::string> warnings;  // process -> its last WARN message
  // By frame seq: a listener can lose a datagram too (raw VGA frames flood its socket in
  // lockstep), and each truth is scored at its own frame's time.
  std::map<int64_t, ptzstereo::sim_truth_t> truths;
  int64_t first_target_seq = -1;  // the first frame whose pose has a target (the acquisition)
  // A click to send (TARGET_SELECT by image point): on the object of this name, where the left
  // camera sees its centre in the frame click_frame, sent once ptz-detect has answered that frame
  // (as an operator clicks on a frame ptz-view shows with its detections).
  std::string click_object;
  int64_t click_frame = -1;
  lcm::LCM* lcm = nullptr;
  bool clicked = false;
  std::optional<ptzstereo::target_select_t> click;

  void onTruth(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::sim_truth_t* m) {
    metrics.onTruth(*m);
    truths.emplace(m->frame_seq, *m);
    if (click || click_frame < 0 || m->frame_seq < click_frame) return;
    for (const auto& o : m->objects) {
      if (o.name != click_object) continue;
      const Eigen::Vector2d px = ptz::tools::toView(m->left_camera)
                                     .project({o.position_m[0], o.position_m[1], o.position_m[2]});
      ptzstereo::target_select_t s{};
      s.mode = ptzstereo::target_select_t::MODE_IMAGE_POINT;
      s.camera = ptzstereo::target_select_t::CAMERA_LEFT;
      s.x_px = px.x();
      s.y_px = px.y();
      s.frame_seq = m->frame_seq;
      click = s;
    }
  }
  void onPose(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::object_pose_t* m) {
    metrics.onPose(*m);
    if (first_target_seq < 0 && m->target_index >= 0) first_target_seq = m->frame_seq;
    if (click && !clicked && lcm && m->frame_seq >= click->frame_seq) {
      click->utime = click->publish_utime = ptz::wallUtime();
      lcm->publish("TARGET_SELECT", &*click);
      clicked = true;
    }
  }
  void onSetpoint(const lcm::ReceiveBuffer*, const std::string&,
                  const ptzstereo::ptz_setpoint_t* m) {
    metrics.onSetpoint(*m);
  }
  void onControlState(const lcm::ReceiveBuffer*, const std::string&,
                      const ptzstereo::control_state_t* m) {
    metrics.onControlState(*m);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    metrics.onStatus(*m);
    auto& c = counters[m->process];
    c["up"] = 1;
    for (const auto& counter : m->counters) c[counter.name] = counter.value;
    if (m->state == ptzstereo::process_status_t::STATE_WARN) warnings[m->process] = m->message;
  }
};

// Starts ptz-detect and ptz-control, waits until both are up, runs ptz-sim to its end.
// target_class: the class the run's numbers score (ptz-detect's own comes from its arguments).
// click_object, click_frame: a click on that object in that frame (Listener).
inline std::unique_ptr<Listener> runLoop(const std::vector<std::string>& sim_args,
                                         const std::vector<std::string>& control_args,
                                         const std::vector<std::string>& detect_args = {},
                                         const std::string& target_class = "red_ball",
                                         const std::string& click_object = "",
                                         int64_t click_frame = -1) {
  using namespace std::chrono_literals;
  lcm::LCM lcm(kTestUrl);
  auto l = std::make_unique<Listener>();
  l->metrics = ptz::tools::RunMetrics(target_class);
  l->click_object = click_object;
  l->click_frame = click_frame;
  l->lcm = &lcm;
  lcm.subscribe("SIM_TRUTH", &Listener::onTruth, l.get());
  lcm.subscribe("OBJECT_POSE", &Listener::onPose, l.get());
  lcm.subscribe("PTZ_SETPOINT", &Listener::onSetpoint, l.get());
  lcm.subscribe("CONTROL_STATE", &Listener::onControlState, l.get());
  lcm.subscribe("PROCESS_STATUS_.*", &Listener::onStatus, l.get());
  std::vector<std::string> detect_cmd = {PTZ_DETECT_BIN, "--lcm-url", kTestUrl, "--config",
                                         kConfig + "detect_default.yaml"};
  detect_cmd.insert(detect_cmd.end(), detect_args.begin(), detect_args.end());
  ChildProcess detect(detect_cmd);
  std::vector<std::string> control_cmd = {PTZ_CONTROL_BIN, "--lcm-url", kTestUrl};
  control_cmd.insert(control_cmd.end(), control_args.begin(), control_args.end());
  ChildProcess control(control_cmd);
  EXPECT_TRUE(handleUntil(
      lcm, [&] { return l->counters["ptz-detect"]["up"] && l->counters["ptz-control"]["up"]; },
      20s))
      << "ptz-detect and ptz-control did not come up";
  std::vector<std::string> cmd = {
      PTZ_SIM_BIN, "--lcm-url", kTestUrl, "--clock", "lockstep", "--lockstep-timeout-ms", "3000"};
  cmd.insert(cmd.end(), sim_args.begin(), sim_args.end());
  ChildProcess sim(cmd);
  handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0; }, 240s);
  drain(lcm, 300ms);
  EXPECT_EQ(sim.wait(0ms), 0);
  l->lcm = nullptr;
  if (click_frame >= 0) {
    EXPECT_TRUE(l->clicked) << "no click was sent on " << click_object;
  }
  return l;
}

}  // namespace ptz::test
