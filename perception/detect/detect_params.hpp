// ptz-detect's own parameters (no LCM): declared for --help, the config file and the flags, and
// read back into what a DetectPipeline is made of. The main declares the transport's and the
// rig's first (addTransportParams, declareRigParams), so --help and the README list those first.
#pragma once

#include <string>

#include "common/config.hpp"
#include "perception/appearance/clicked.hpp"
#include "perception/detection/detector.hpp"
#include "perception/detection/orientation.hpp"
#include "perception/detection/stereo.hpp"
#include "perception/detection/windows.hpp"
#include "perception/markers/marker_scan.hpp"
#include "perception/people/people_scan.hpp"
#include "perception/tracking/tracker.hpp"

namespace ptz::perception {

// Declares target_class .. full_scan_max_width_px, the freshness of frames (frame_*) and of
// TARGET_SELECT requests (select_*), the markers' (marker_*), the faces' and people's (people_*),
// and the config file's sections `classes`, `markers` and `people`.
void declareDetectParams(Params& p);

// The tracker's parameters from track_*.
TrackerParams trackerParams(const Params& p);
// The windows' parameters from windows, window_*, full_scan_max_width_px.
WindowParams windowParams(const Params& p);

// What a DetectPipeline is made of (the defaults are the parameters').
struct DetectConfig {
  DetectorParams detector;  // the classes, the filters
  StereoParams stereo;
  TrackerParams tracker;
  WindowParams windows;
  std::string target_class = "red_ball";  // followed until TARGET_SELECT says otherwise
  double pick_radius_px = 15.0;           // TARGET_SELECT by image point
  double trusted_area_ratio = 1.3;        // trackMeasurements' lr_area
  bool orientation = true;                // the yaw of boxes
  OrientationParams orientation_params;
  int orientation_margin_px = 8;
  int orientation_max_per_frame = 4;
  // Fiducial markers (the config file's section `markers`; none: not scanned for).
  std::vector<MarkerClass> markers;
  MarkerScanParams marker_scan;
  // Tags', faces' and people's search for new ones after the frame's messages (discover()).
  bool new_objects_after_publish = true;
  // That search on a thread of its own (NewObjectSearch), this much nicer than ptz-detect.
  bool new_objects_background = true;
  int new_objects_nice_increment = 10;
  // A point on no track starts a model of what is under it (appearance/clicked.hpp).
  bool click_to_track = true;
  ClickedParams clicked;
  // Faces and people (the config file's section `people`; none: not scanned for).
  std::vector<PeopleClass> people;
  PeopleScanParams people_scan;

  // From parsed parameters. The classes come from the config file, which is therefore required;
  // throws ConfigError naming the file, flag or field (no config file, a class's field, an even
  // filter_size_px, a target_class none of the classes).
  static DetectConfig fromParams(const Params& p);
};

}  // namespace ptz::perception
