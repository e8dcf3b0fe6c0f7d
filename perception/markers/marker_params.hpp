// Fiducial marker classes of ptz-detect's config (no LCM): which markers an object carries and
// where. A class is either single tags (each id seen, or each listed one, an object of its own
// named "<name>#<id>" whose frame is the tag's) or a rigid bundle (one object named "<name>",
// several tags at known poses in its frame, e.g. the faces of a tagged box).
// A tag's frame and its rotation in an object: common/markers.hpp.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace ptz::perception {

struct MarkerTag {
  int id = 0;
  // The tag's centre and rotation object <- tag, in the object's frame.
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation_object_tag = Eigen::Matrix3d::Identity();
};

struct MarkerClass {
  std::string name;
  std::string detector = "apriltag";  // "apriltag" (libapriltag) or "aruco" (OpenCV contrib)
  std::string family = "apriltag_36h11";
  double size_m = 0.1;  // edge of the black square (its outer corners are the ones detected)
  // Single tags: these ids (any_id: every id of the family).
  std::vector<int> ids;
  bool any_id = false;
  // A bundle: its tags (non-empty: the class is one object "<name>").
  std::vector<MarkerTag> bundle;

  bool isBundle() const { return !bundle.empty(); }
  // The object name of a tag seen ("" when the class does not take that id).
  std::string objectName(int id) const;
  // The tag of a bundle with this id (nullptr: none); a single tag's pose is the object's.
  const MarkerTag* bundleTag(int id) const;
  // The four outer corners of tag `id` in the object's frame, in the detectors' order: top-left,
  // top-right, bottom-right, bottom-left as printed.
  std::vector<Eigen::Vector3d> corners(int id) const;
  // The radius of a sphere about the object's origin that holds every tag of it.
  double radiusM() const;
};

// Every object name the classes can make ("<class>#<id>" for each id one takes; a bundle's name).
std::vector<std::string> markerObjectNames(const std::vector<MarkerClass>& classes);

// Reads the config section `markers` (a list of maps: name, detector, family, size_m, and ids: a
// list or "any", or tags: a list of {id, centre_m: [x, y, z], yaw_deg, pitch_deg}); an absent or
// empty section: none. Errors name the file, the field and the value.
std::vector<MarkerClass> markerClassesFromConfig(const cv::FileNode& markers,
                                                 const std::string& where);

}  // namespace ptz::perception
