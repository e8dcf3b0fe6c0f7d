// ptz-sim's run without LCM: the simulator behind its two clocks, the PTZ_STATEs on the way,
// the setpoints and the frames' truth. Realtime: frames every period of wall time, setpoints act
// when they arrive (plus tau). Lockstep: sim time advances by one frame once the answer to the
// frame (a setpoint naming it) came, or after lockstep_timeout_ms; the answer acts from the
// frame's capture time. With served heads (VISCA or ONVIF cameras, ptz-driver between the
// controller and the motors) the answer is the controller's setpoint for the frame, seen, then
// the first camera command after it (or, an unchanged command not being sent again, none within
// lockstep_served_wait_ms). The main serves LCM and publishes through the callbacks.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "common/config.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "sim/simulator.hpp"

namespace ptz::sim {

// Sim time 0 of a lockstep run, so that two runs give identical messages.
constexpr int64_t kLockstepEpochUtime = 1'700'000'000'000'000;

// ptz-sim's parameters but the transport's and the image encoding's, in --help's order: the
// plant, the rig and the clock; then, after the encoding's, the noise, the lockstep timeout, the
// setpoints' freshness, VISCA, ONVIF and the scene's sections.
void declareSimClockParams(Params& p);
void declareSimSceneParams(Params& p);
// The simulator the parameters describe; throws ConfigError for a bad scene.
std::unique_ptr<Simulator> simulatorFromParams(const Params& p);
// The VISCA model file the heads pretend to be; empty when they speak LCM (visca_port 0). Throws
// ConfigError for visca_port in lockstep or without a model.
std::string viscaModelPath(const Params& p);
// The ONVIF model file (onvif_port); empty when off. Throws ConfigError for onvif_port in
// lockstep, with visca_port, or without a model.
std::string onvifModelPath(const Params& p);

struct SimClock {
  bool lockstep = false;
  double frame_period_s = 1.0 / 30;
  double state_period_s = 0.01;
  double lockstep_timeout_ms = 1000;
  bool served_heads = false;  // VISCA or ONVIF cameras: ptz-driver commands the motors
  double lockstep_served_wait_ms = 60;
  // Throws ConfigError for a clock other than realtime or lockstep.
  static SimClock fromParams(const Params& p);
};

// What became of a setpoint.
struct SetpointOutcome {
  std::string dropped;  // why it was dropped (lockstep: setpoint_stale); empty: applied
  int clamped = 0;      // values beyond a limit, clamped to it
  int rejected = 0;     // non-finite values: their axes hold
};

enum class Answer { kAnswered, kTimedOut, kStopped };

class SimRun {
 public:
  // A PTZ_STATE due (utime and setpoint_utime set; the main stamps publish_utime).
  using StateSink = std::function<void(ptzstereo::ptz_state_t*)>;
  // Handles the input arriving within timeout_ms (0: what waits); false once the process stops.
  using Serve = std::function<bool(int timeout_ms)>;

  SimRun(std::unique_ptr<Simulator> sim, const SimClock& clock, StateSink publish_state);

  bool lockstep() const { return clock_.lockstep; }
  // The utime of sim instant t_s. Lockstep: from kLockstepEpochUtime. Realtime: the wall clock
  // now, less how long ago t_s was on the steady clock, so stamps follow the wall clock's steps
  // and NTP's slewing (what every other process judges freshness by) instead of drifting.
  int64_t simUtime(double t_s) const;
  // Seconds of the steady clock since the run began (realtime's sim time).
  double realtimeNow() const;

  // Advances the motors to t_s, a PTZ_STATE at every state period on the way.
  void advanceWithStates(double t_s);
  // Realtime: serves input and states until the frame's time, then advances to it; false when the
  // frame is more than a period late (skip it).
  bool waitForFrame(double t_frame_s, const Serve& serve);
  // Lockstep: serves input until the answer to frame seq came, or lockstep_timeout_ms.
  Answer awaitAnswer(int64_t seq, const Serve& serve);

  struct Capture {
    SimFrame frame;  // rendered
    ptzstereo::sim_truth_t truth;
    int64_t utime = 0;  // one stamp for the frame, its truth and its preview
  };
  // The frame of the current instant and its truth (the motors may move on while it renders).
  Capture capture();

  // A PTZ_SETPOINT (realtime: found fresh by the caller).
  SetpointOutcome applySetpoint(const ptzstereo::ptz_setpoint_t& m);
  // f with the motors advanced to now (lockstep: the frozen sim time), under their lock (the
  // served cameras' threads).
  void withMotorsNow(const std::function<void(Simulator& sim, double t_s)>& f);
  // Lockstep with served heads: the controller's PTZ_SETPOINT answering frame_seq was seen (it is
  // not applied: the cameras' commands are), and a served camera applied a command.
  void noteControllerAnswer(int64_t frame_seq);
  void noteServedCommand() { ++served_commands_; }

 private:
  std::unique_ptr<Simulator> sim_;
  SimClock clock_;
  StateSink publish_state_;
  // The motors are shared with the VISCA thread (visca_port): every use of the plant holds
  // motors_; the renderers are the main thread's alone.
  std::mutex motors_;
  std::chrono::steady_clock::time_point start_steady_;
  double next_state_t_ = 0;
  double current_frame_t_ = 0;
  int64_t awaiting_seq_ = -1;  // the main thread's alone
  bool answered_ = false;
  // Served heads: the commands applied so far (the cameras' threads count them), and how many
  // there were when the controller's answer was seen, and when.
  std::atomic<int64_t> served_commands_{0};
  int64_t commands_at_answer_ = 0;
  std::chrono::steady_clock::time_point answered_at_;
  int64_t last_setpoint_utime_ = 0;
};

}  // namespace ptz::sim
