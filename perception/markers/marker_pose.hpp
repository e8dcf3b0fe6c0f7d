// The pose of a tagged object from both views together (no LCM): the tags' corners triangulated
// with the frame's own geometry, the object's frame fitted to them (Umeyama), then refined by
// least squares on every corner's reprojection in both views (a corner seen in one view counts
// too), with the covariance of rotation and position from the fit. Not two monocular PnPs: the
// depth comes from the baseline, so a small tag far away keeps its range.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

#include "common/rig.hpp"
#include "perception/markers/marker_detector.hpp"

namespace ptz::perception {

// One corner of an object's tags: where it is on the object and where each view saw it.
struct MarkerCorner {
  Eigen::Vector3d model_m = Eigen::Vector3d::Zero();  // object frame
  bool seen[2] = {false, false};                      // left, right
  Eigen::Vector2d pixel[2];                           // distorted image coordinates
};

struct MarkerPoseParams {
  double corner_sigma_px = 0.3;  // a corner's noise (the covariance's floor)
  double max_rms_px = 1.5;       // a fit whose reprojection RMS exceeds this is refused
  double max_corner_px = 1.0;    // and one with a corner this far off it (a tag partly hidden)
  double min_range_m = 0.3, max_range_m = 50;
};

struct MarkerPose {
  Eigen::Matrix3d rotation_head_object = Eigen::Matrix3d::Identity();
  Eigen::Vector3d position_head_m = Eigen::Vector3d::Zero();
  // Rotation-vector error in the head frame (R = exp(e) R_est), rad, then position, m: 6x6.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
  double rms_px = 0;
  int stereo_corners = 0;  // corners triangulated (seen in both views)
};

// False and *why ("reason: detail", reason one of few_corners, collinear, not_finite,
// reprojection, corner_residual, range, unobservable) when fewer than three corners are seen in
// both views (or they are in a line), its RMS exceeds max_rms_px or a corner's residual
// max_corner_px, or the object is out of range.
bool estimateMarkerPose(const std::vector<MarkerCorner>& corners, const CameraView& left,
                        const CameraView& right, const MarkerPoseParams& params, MarkerPose* pose,
                        std::string* why);

// A tagged object of one frame: its class, name ("<class>#<id>" or the bundle's), the sightings
// that made it in each view and its pose.
struct MarkerObject {
  int class_index = -1;
  std::string name;
  std::vector<int> sightings[2];  // indices into each view's sightings
  MarkerPose pose;
  double radius_m = 0;
};

// The objects of a frame from both views' sightings: a tag seen twice in one view (two tags of one
// id, so which is which cannot be told) makes none. Objects whose pose fails are left out and
// counted in *failed by reason (estimateMarkerPose's, or tag_seen_twice).
std::vector<MarkerObject> markerObjects(const std::vector<MarkerClass>& classes,
                                        const std::vector<MarkerSighting>& left,
                                        const std::vector<MarkerSighting>& right,
                                        const CameraView& left_view, const CameraView& right_view,
                                        const MarkerPoseParams& params,
                                        std::vector<std::string>* failed);

}  // namespace ptz::perception
