// Where ptz-detect looks for tags in a frame (no LCM): a window around each tag of a tagged track
// that faces the camera (its predicted corners, at full resolution; the whole object's window while
// its orientation is not known), and one band of the image's rows a frame for new tags
// (the whole image every `bands` frames, on the image halved by libapriltag: a whole VGA image
// costs 9-19 ms, a band an eighth of it). Both cameras on two cores; then the tagged objects'
// poses from both views.
#pragma once

#include <opencv2/core.hpp>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "perception/detection/windows.hpp"
#include "perception/markers/marker_pose.hpp"
#include "perception/tracking/tracker.hpp"

namespace ptz::perception {

struct MarkerScanParams {
  int bands = 8;                       // the image searched for new tags in this many bands
  double band_overlap_fraction = 0.1;  // each band reaches this share of the height further
  double band_decimate =
      1.5;  // libapriltag's quad_decimate in bands (windows: 1); 2 misses 40 px tags
  // A window larger than this many times its object's image (its uncertainty, not the object:
  // a track lost a while) is searched with the band, which the frame's messages do not wait for.
  double window_max_object_areas = 9;
  // The tracker's rotation filter: a tag window's growth with the orientation's uncertainty.
  RotationFilterParams rotation;
  MarkerDetectorParams detector;
  MarkerPoseParams pose;
};

struct MarkerScan {
  std::vector<MarkerSighting> sightings[2];  // left, right
  std::vector<MarkerObject> objects;
};

class MarkerScanner {
 public:
  static constexpr size_t kMaxSightings = 64;  // a view's, a frame (the rest counted)
  MarkerScanner(std::vector<MarkerClass> classes, MarkerScanParams params, cv::Size image);

  bool enabled() const { return !classes_.empty(); }
  // Whether a track's class is a tagged object's; the index of its marker class (-1: none).
  bool isMarkerObject(const std::string& class_name) const;
  int classOf(const std::string& class_name) const;

  // One frame: windows around the tracks of tagged objects (predicted to t_s, windows' params),
  // this frame's band (the next band a call) and the lost tracks' windows (parts: the windows, the
  // band and lost windows, or both); the sightings (a tag found
  // in a window and the band counted once) and the objects. False when a crop fails (*why).
  bool scan(const std::vector<Track>& tracks, double t_s, const CameraView& left,
            const CameraView& right, const WindowParams& windows, const CropPixels crop[2],
            MarkerScan* out, std::string* why, ScanParts parts = ScanParts::kBoth);

  // marker_windows, marker_tag_windows (a track's windows around its tags), marker_windows_lost
  // (larger than window_max_object_areas times the object's image: searched with the band),
  // marker_windows_left_to_bands (larger than windows' max_cover_fraction of the image),
  // marker_bands_scanned, marker_sightings, marker_sightings_capped, marker_objects,
  // marker_ids_unclaimed, marker_cut_by_part (a tag crossing its window's or band's edge, not the
  // image's: refused, its corners guessed), marker_refused_{hamming,margin,small},
  // marker_pose_failed_<reason>;
  // since the start.
  const std::map<std::string, int64_t>& counts() const { return counts_; }
  const std::vector<MarkerClass>& classes() const { return classes_; }

  // A tag is looked for where it faces a camera by more than this (the cosine of 84 degrees).
  static constexpr double kMinFacingCos = 0.1;
  // The windows of a tagged track's tags that face a view: each tag's predicted corners, grown by
  // k sigma of the track's position and of its rotation times the corner's distance from the
  // object's origin, and by a quarter of the tag (its white border). False when the track's
  // orientation is not known or no tag of it faces the view (then its object's window).
  bool tagWindows(const CameraView& view, const Track& t, const MarkerClass& c, double t_s,
                  const WindowParams& windows, std::vector<cv::Rect>* out) const;
  // Whether a coasting track's window in a view is mostly its uncertainty
  // (window_max_object_areas).
  bool lost(const CameraView& view, const Track& t, double t_s, const WindowParams& windows) const;

 private:
  std::vector<MarkerClass> classes_;
  MarkerScanParams p_;
  cv::Size size_;
  std::unique_ptr<MarkerDetector> detectors_[2];  // one per camera: libapriltag keeps state
  int next_band_ = 0;
  std::map<std::string, int64_t> counts_;
};

}  // namespace ptz::perception
