// ptz-detect's results as the message contract's types (no LCM): a region as a detection_2d_t,
// a triangulated object as an object_3d_t, a track as an object_track_t. A yaw about the head's
// y axis is a quaternion with its variance the covariance's y-y entry.
#pragma once

#include <string>

#include "perception/detection/detector.hpp"
#include "perception/detection/orientation.hpp"
#include "perception/detection/stereo.hpp"
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

// A track at now_s (its age, time since its update and yaw variance then).
ptzstereo::object_track_t toMessage(const Track& t, double now_s, double yaw_psd_rad2_s);
// A track moved by one view alone (Tracker::updateFromViews), as an object of OBJECT_POSE: its
// position and covariance, the view's region index and -1 for the other view.
ptzstereo::object_3d_t viewObject(const Track& t);

}  // namespace ptz::perception
