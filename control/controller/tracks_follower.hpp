// ptz-control's work on one OBJECT_TRACKS, without LCM: the target track as an observation, its
// plausibility, the controller's step, and the PTZ_SETPOINT and CONTROL_STATE that answer the
// frame (utime and frame_seq of the frame; the main stamps publish_utime and publishes them).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "control/controller/controller.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"

namespace ptz::control {

// A counted event of a message and, when not empty, what stderr says of it.
struct CountedEvent {
  std::string counter;
  std::string message;
};

struct TracksAnswer {
  // Set: the message is dropped for this reason (nonfinite_ptz) and nothing else happened.
  std::optional<CountedEvent> dropped;
  // Counters to add one to: the target's problems (target_not_in_tracks, target_bad_state,
  // implausible_poses) and the setpoint's kind (setpoints_tracking or setpoints_without_target,
  // setpoints_<state>).
  std::vector<CountedEvent> events;
  ptzstereo::ptz_setpoint_t setpoint{};
  ptzstereo::control_state_t state{};
  bool reason_changed = false;  // the state's reason is not the previous answer's
};

// The target track of a tracks message as an observation (none when there is no target, or it is
// tentative). *problem: why a target named by target_id cannot be used ("" when it can).
std::optional<Observation> targetOf(const ptzstereo::object_tracks_t& m, std::string* problem);

class TracksFollower {
 public:
  TracksFollower(StereoRig rig, ControllerParams params);

  TracksAnswer follow(const ptzstereo::object_tracks_t& m);
  const Controller& controller() const { return controller_; }

 private:
  ptzstereo::control_state_t stateMessage(const ptzstereo::object_tracks_t& m,
                                          int64_t target_id) const;

  Controller controller_;
  std::string last_reason_;
};

}  // namespace ptz::control
