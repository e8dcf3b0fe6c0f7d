// Fiducial marker families (no LCM): their codes as cells, for the simulator to draw and the
// detectors to name. A family is one of OpenCV's predefined ArUco dictionaries by its name in
// lower case without DICT_ ("apriltag_36h11", "aruco_4x4_50", "aruco_original"); the AprilTag ones
// hold the same codes as libapriltag's families of that name (tag36h11, ...).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace ptz {

// The families by name, in OpenCV's order.
const std::vector<std::string>& markerFamilies();
// Whether OpenCV's dictionary holds the family's codes turned by half a turn against the tags as
// printed (the AprilTag families: their top-left corner is OpenCV's bottom-right).
bool markerFamilyUpsideDownInOpenCv(const std::string& family);
// Ids of a family (0 .. count - 1); 0 for an unknown name.
int markerFamilyCount(const std::string& family);
// OpenCV's cv::aruco::PREDEFINED_DICTIONARY_NAME of a family; -1 for an unknown name.
int markerFamilyDictionary(const std::string& family);

// The marker `id` of `family` as (bits + 2)^2 cells, row by row from its top-left corner as
// printed (an AprilTag as libapriltag draws it): 0 black, 255 white; the outer ring is the black
// border, whose outer corners the detectors report. False and *why for an unknown family or an id
// out of range.
bool markerCells(const std::string& family, int id, cv::Mat* cells, std::string* why);

// A tag's frame: origin at its centre, x to its right, y down, z into it (away from a camera that
// faces it). Its rotation object <- tag from yaw (about the object's y) then pitch (about x), in
// degrees: yaw 0, pitch 0 is the face at the object's -z, facing a camera that looks along +z.
Eigen::Matrix3d tagRotation(double yaw_deg, double pitch_deg);

}  // namespace ptz
