// ptz-view's drawing (no LCM, no window): both camera images side by side with the detections,
// the image centre cross, the target's epipolar line in the other image, and a text panel with
// each camera's PTZ and setpoint, the target's 3D position and range, the loop delay and rates.
#pragma once

#include <opencv2/core.hpp>

#include <optional>

#include "common/rig.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"

namespace ptz::tools {

// Overlay colours (BGR), fixed so tests and users can tell them apart.
inline const cv::Scalar kCentreColour(255, 255, 0);     // cyan: image centre cross
inline const cv::Scalar kDetectionColour(0, 255, 255);  // yellow: other detections
inline const cv::Scalar kTargetColour(255, 0, 255);     // magenta: the target
inline const cv::Scalar kEpipolarColour(0, 255, 0);     // green: the target's epipolar line
constexpr int kPanelHeightPx = 130;

struct ViewInput {
  cv::Mat left, right;          // BGR, the frame's images
  PtzPose left_ptz, right_ptz;  // at capture
  int64_t seq = 0;
  std::optional<ptzstereo::object_detections_t> detections;  // of this frame
  std::optional<ptzstereo::object_pose_t> pose;              // of this frame
  std::optional<ptzstereo::ptz_setpoint_t> setpoint;         // the latest
  double delay_ms_p50 = NAN, delay_ms_p99 = NAN;             // ptz-control's monitor
  double frame_rate_hz = 0, drawn_rate_hz = 0;
  int64_t frames_dropped = 0;  // not drawn: the viewer was busy
  bool paused = false;
};

// The canvas: left | right, then the text panel (width 2 W, height H + kPanelHeightPx).
cv::Mat drawView(const StereoRig& rig, const ViewInput& in);

}  // namespace ptz::tools
