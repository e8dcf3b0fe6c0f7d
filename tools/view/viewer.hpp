// ptz-view's drawing (no LCM, no window): both camera images side by side with the detections,
// the tracks (id, class, state, axes of those with an orientation; the target), the image centre
// cross, the target's epipolar line in the other image, and a text panel with each camera's PTZ and
// setpoint, the target's 3D position and range, the controller's state, the loop delay and rates.
// And what a click on it asks for.
#pragma once

#include <opencv2/core.hpp>

#include <optional>

#include "common/rig.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/target_select_t.hpp"

namespace ptz::tools {

// Overlay colours (BGR), fixed so tests and users can tell them apart.
inline const cv::Scalar kCentreColour(255, 255, 0);     // cyan: image centre cross
inline const cv::Scalar kDetectionColour(0, 255, 255);  // yellow: other detections
inline const cv::Scalar kTargetColour(255, 0, 255);     // magenta: the target
inline const cv::Scalar kEpipolarColour(0, 255, 0);     // green: the target's epipolar line
// Tracks: confirmed solid, tentative thin and dashed, coasting (a prediction) in its own colour;
// the target track in kTargetColour, labelled TARGET. Each has an x at its projected centre.
inline const cv::Scalar kTrackColour(0, 128, 255);     // orange: confirmed and tentative tracks
inline const cv::Scalar kCoastingColour(255, 128, 0);  // azure: coasting tracks
constexpr int kPanelHeightPx = 160;
// At most this many tracks are drawn (the rest counted in the panel): bounds a frame's cost.
constexpr int kMaxTracksDrawn = 64;

struct ViewInput {
  cv::Mat left, right;          // BGR, the frame's images
  PtzPose left_ptz, right_ptz;  // at capture
  int64_t seq = 0;
  std::optional<ptzstereo::object_detections_t> detections;  // of this frame
  std::optional<ptzstereo::object_pose_t> pose;              // of this frame
  std::optional<ptzstereo::object_tracks_t> tracks;          // of this frame
  std::optional<ptzstereo::ptz_setpoint_t> setpoint;         // the latest
  std::optional<ptzstereo::control_state_t> control;         // the latest
  double delay_ms_p50 = NAN, delay_ms_p99 = NAN;             // ptz-control's monitor
  double frame_rate_hz = 0, drawn_rate_hz = 0;
  int64_t frames_dropped = 0;  // not drawn: the viewer was busy
  bool paused = false;
};

// The canvas: left | right, then the text panel (width 2 W, height H + kPanelHeightPx).
cv::Mat drawView(const StereoRig& rig, const ViewInput& in);

// The controller's state as the panel shows it: "TRACKING", "COASTING 0.4 s", "SEARCHING 3/8"
// (the waypoint visited, from 1), "HOLDING 1.2 s", "HOMING".
std::string controlStateText(const ptzstereo::control_state_t& s);

// A click at canvas pixel (x, y) of a canvas drawView made from images image_width x image_height:
// a TARGET_SELECT MODE_IMAGE_POINT of the camera clicked at that pixel of its own image (the right
// image's offset undone), for frame frame_seq, stamped now_utime. None: outside both images.
// highgui reports mouse positions in the shown image's pixels whatever the window's zoom, so
// there is no display scale to undo.
std::optional<ptzstereo::target_select_t> clickToSelect(int x, int y, int image_width,
                                                        int image_height, int64_t frame_seq,
                                                        int64_t now_utime);

}  // namespace ptz::tools
