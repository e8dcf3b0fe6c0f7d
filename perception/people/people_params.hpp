// Face and person classes of ptz-detect's config (no LCM): which of OpenCV's detectors finds them
// (its HOG people detector, or a Haar/LBP cascade such as Debian opencv-data's frontal faces), and
// how tall the object is, which gives the windows around its track and refuses a detection whose
// size does not fit its range.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/objdetect.hpp>

#include <string>
#include <vector>

namespace ptz::perception {

struct PeopleClass {
  std::string name;
  std::string detector = "hog";  // "hog" (OpenCV's people detector) or "cascade"
  // cascade: the name of one of Debian opencv-data's (haarcascade_frontalface_default, ...) or a
  // YAML file of one's own.
  std::string cascade;
  double height_m = 1.75;  // the object's height (a face's: chin to hairline, ~0.22)
  // The detector's box against the object: its height over the object's, its width over its
  // height, and the height of the smallest box it finds.
  double box_height_ratio = 4.0 / 3, box_aspect = 0.5, min_box_px = 128;
  // The object's centre above the box's centre, a share of the box's height (HOG's boxes reach
  // further below the feet than above the head: measured on the simulator's figure).
  double centre_above_box_fraction = 0.025;
  // The part of the box matched in the other view (fractions of its width and height, centred):
  // the object, little of what is behind it.
  double patch_width_fraction = 0.3, patch_height_fraction = 0.75;
  double scan_scale = 0.5;        // new objects are looked for on the image scaled by this
  double max_box_fraction = 1.0;  // ... as tall as this share of the image's height at most
  int min_neighbors = 3;          // cascade: overlapping hits a detection needs
};

// The detectors' defaults for a class of that detector.
PeopleClass defaultPeopleClass(const std::string& detector);

// Loads a cascade: by name one Debian opencv-data installed (/usr/share/opencv4/*cascades/), else
// a YAML file through the project's checked reader; throws ConfigError naming it.
void loadCascade(const std::string& path, cv::CascadeClassifier* out);

// Reads the config section `people` (a list of maps: name, detector, cascade, height_m,
// scan_scale, min_neighbors); an absent or empty section: none. A cascade file is checked to load.
// Errors name the file, the field and the value.
std::vector<PeopleClass> peopleClassesFromConfig(const cv::FileNode& people,
                                                 const std::string& where);

}  // namespace ptz::perception
