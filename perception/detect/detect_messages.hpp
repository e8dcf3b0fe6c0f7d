// ptz-detect's results as the message contract's types (no LCM): a region as a detection_2d_t,
// a triangulated object as an object_3d_t, a track as an object_track_t. A yaw about the head's
// y axis is a quaternion with its variance the covariance's y-y entry; a tagged object's is whole.
#pragma once

#include <string>

#include "perception/appearance/clicked.hpp"
#include "perception/detection/detector.hpp"
#include "perception/detection/orientation.hpp"
#include "perception/detection/stereo.hpp"
#include "perception/markers/marker_pose.hpp"
#include "perception/tracking/tracker.hpp"
#include "ptzstereo/detection_2d_t.hpp"
#include "ptzstereo/object_3d_t.hpp"
#include "ptzstereo/object_track_t.hpp"

namespace ptz::perception {

// A region of class dp.classes[r.class_index], matched to none yet (match_index -1).
ptzstereo::detection_2d_t toMessage(const Region& r, const DetectorParams& dp);

// A stereo object of class class_name, its radius and its box's yaw (none when !yaw.ok).
ptzstereo::object_3d_t toMessage(const StereoObject& o, const std::string& class_name,
                                 double radius_m, const BoxYaw& yaw);

// A track at now_s (its age, time since its update, its yaw's or full orientation's variance
// then, by the tracker's random walks).
ptzstereo::object_track_t toMessage(const Track& t, double now_s, const TrackerParams& p);

// A tag seen in one view as a detection of its object ("<class>#<id>" or the bundle's name): the
// tag's centre, the area and box of its four corners, shape_distance 0, matched to none yet.
ptzstereo::detection_2d_t toMessage(const MarkerSighting& s, const std::string& object_name);
// An object seen as a patch in both views (the clicked object, a face, a person): its patch in
// view `side` (0 left, 1 right) as a detection of its class.
ptzstereo::detection_2d_t toMessage(const PatchObject& o, int side);
// Such an object (no orientation) with its detections' indices.
ptzstereo::object_3d_t toMessage(const PatchObject& o, int left_index, int right_index);
// A tagged object: its pose (position and rotation with their covariances) and the detection
// indices of its first tag in each view (-1: not seen there).
ptzstereo::object_3d_t toMessage(const MarkerObject& o, int left_index, int right_index);
// A track moved by one view alone (Tracker::updateFromViews), as an object of OBJECT_POSE: its
// position and covariance, the view's region index and -1 for the other view.
ptzstereo::object_3d_t viewObject(const Track& t);

}  // namespace ptz::perception
