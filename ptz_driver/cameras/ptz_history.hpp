// Where each camera pointed at a given time: a short history of PTZ_STATE, interpolated linearly
// by time, so that an image carries its camera's pan/tilt/zoom at its own capture time.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>

#include "common/rig.hpp"  // PtzPose, Side

namespace ptz::driver {

struct PtzLookup {
  PtzPose pose;
  // No state at all, or the time lies outside the history by more than the allowed
  // extrapolation: the pose is then the nearest state's (home without any state).
  bool stale = false;
};

class PtzHistory {
 public:
  // Keeps the states of the last history_s (at least two); times up to max_extrapolation_s
  // outside the history get the nearest state without being stale.
  PtzHistory(double history_s, double max_extrapolation_s);

  // False (state ignored) when utime is not after the newest state's, unless it is older by
  // more than history_s: time went backwards (a looped log, a restarted simulator, an NTP step)
  // and the history starts again from this state (counted by restarts()).
  bool add(int64_t utime, const PtzPose& left, const PtzPose& right);
  PtzLookup at(Side side, int64_t utime) const;
  size_t size() const { return states_.size(); }
  std::optional<int64_t> newestUtime() const;
  int64_t restarts() const { return restarts_; }

 private:
  struct State {
    int64_t utime;
    std::array<PtzPose, 2> pose;
  };
  int64_t history_us_, max_extrapolation_us_;
  std::deque<State> states_;
  int64_t restarts_ = 0;
};

}  // namespace ptz::driver
