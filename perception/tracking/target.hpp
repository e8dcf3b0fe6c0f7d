// Which track the system follows (no LCM). Once locked it stays on that track while the track
// exists, whatever else of its class appears; when the track is deleted the selector remembers
// where it was going and, for 5 s, takes the confirmed track of the class nearest that
// prediction, when it is clearly the nearest (at most half the next one's distance) and was not
// born beside the lost one (in a merge of look-alikes, where it may be either). Without that it
// takes the confirmed track of the class nearest the home optical axis (+z of the head frame),
// never the largest. Requests (by class, track id or image point) change the choice; a request that
// cannot be met is refused with a reason and changes nothing.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "perception/tracking/tracker.hpp"

namespace ptz::perception {

struct TargetRequest {
  enum class Mode { kClass, kTrackId, kImagePoint };
  Mode mode = Mode::kClass;
  std::string class_name;  // kClass ("" = the default class)
  int64_t track_id = -1;   // kTrackId
  Side camera = Side::kLeft;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // kImagePoint, distorted image coordinates
};

class TargetSelector {
 public:
  // known_classes: the detector's classes (a request for another is refused).
  TargetSelector(std::string default_class, std::vector<std::string> known_classes,
                 double pick_radius_px = 15.0);

  // After each tracker update at t_s: the id followed (-1 none). views: the frame's cameras.
  int64_t choose(double t_s, const std::vector<Track>& tracks);
  // Applies a request against the current tracks and views; false (and *why) when refused.
  bool request(const TargetRequest& r, const std::vector<Track>& tracks, const CameraView& left,
               const CameraView& right, std::string* why);

  // Lets go of the locked track (and of a lost one's prediction), saying why; the class stays.
  void release(const std::string& why);
  int64_t targetId() const { return locked_id_; }
  const std::string& targetClass() const { return class_; }
  const std::string& reason() const { return reason_; }

 private:
  void lock(const Track& t, const std::string& why);

  std::string default_class_;
  std::vector<std::string> known_classes_;
  double pick_radius_px_;
  std::string class_;
  int64_t locked_id_ = -1;
  std::string reason_ = "no target yet";
  // The lost target: its last state, to re-acquire by prediction.
  std::optional<Track> lost_;
};

}  // namespace ptz::perception
