// What ptz-view keeps between messages, without LCM or a window: the newest frame not drawn yet
// (a queue of one), the detections, poses and tracks by frame_seq until their frame is drawn
// (bounded), the latest setpoint, controller state and loop delay, the frame rates; when a frame
// is ready to draw and the panel's input for it.
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>

#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "tools/view/viewer.hpp"

namespace ptz::tools {

class ViewState {
 public:
  explicit ViewState(int64_t max_wait_us) : max_wait_us_(max_wait_us) {}

  // A frame arrived at now_us. Paused (and no step asked for), it is not kept; otherwise it
  // replaces the one waiting. Either way a frame is not drawn: counted in framesNotDrawn().
  void onFrame(const ptzstereo::stereo_frame_t& m, int64_t now_us, bool paused);
  void onDetections(const ptzstereo::object_detections_t& m);
  void onPose(const ptzstereo::object_pose_t& m);
  void onTracks(const ptzstereo::object_tracks_t& m);
  void onSetpoint(const ptzstereo::ptz_setpoint_t& m) { setpoint_ = m; }
  void onControlState(const ptzstereo::control_state_t& m) { control_ = m; }
  // ptz-control's status: its loop delay percentiles.
  void onControlStatus(const ptzstereo::process_status_t& m);

  // The waiting frame once its detections and pose (and tracks, once any came) are in, or it
  // has waited max_wait_us; null otherwise.
  const ptzstereo::stereo_frame_t* ready(int64_t now_us) const;
  // The panel's input for the waiting frame drawn at now_us (its images left to the caller).
  ViewInput input(int64_t now_us, bool paused) const;
  // The waiting frame was drawn at now_us (or, drawn false, dropped): what belongs to it and to
  // older frames is forgotten.
  void done(bool drawn, int64_t now_us);
  int64_t framesNotDrawn() const { return frames_not_drawn_; }
  size_t keptForFrames() const;  // detections, poses and tracks kept

  // Messages for frames not drawn yet, by frame_seq: at most this many of each.
  static constexpr size_t kKept = 64;

 private:
  template <class Map>
  void keepRecent(Map* by_seq) const;
  void forgetUpTo(int64_t seq);

  int64_t max_wait_us_;
  struct Pending {
    ptzstereo::stereo_frame_t frame;
    int64_t received_us;
  };
  std::optional<Pending> pending_;
  std::map<int64_t, ptzstereo::object_detections_t> detections_by_seq_;
  std::map<int64_t, ptzstereo::object_pose_t> poses_by_seq_;
  std::map<int64_t, ptzstereo::object_tracks_t> tracks_by_seq_;
  bool tracks_seen_ = false;
  int64_t newest_frame_seq_ = 0;
  std::optional<ptzstereo::ptz_setpoint_t> setpoint_;
  std::optional<ptzstereo::control_state_t> control_;
  double delay_ms_p50_ = NAN, delay_ms_p99_ = NAN;
  std::deque<int64_t> frame_times_us_, drawn_times_us_;  // the last second's
  int64_t frames_not_drawn_ = 0;
};

}  // namespace ptz::tools
