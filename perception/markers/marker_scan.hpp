// Where ptz-detect looks for tags in a frame (no LCM): a window around each tagged object's track
// (its predicted image, at full resolution), and one band of the image's rows a frame for new tags
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
  // this frame's band (the next band a call; parts: which of the two); the sightings (a tag found
  // in a window and the band counted once) and the objects. False when a crop fails (*why).
  bool scan(const std::vector<Track>& tracks, double t_s, const CameraView& left,
            const CameraView& right, const WindowParams& windows, const CropPixels crop[2],
            MarkerScan* out, std::string* why, ScanParts parts = ScanParts::kBoth);

  // marker_windows, marker_windows_left_to_bands (larger than windows' max_cover_fraction of the
  // image), marker_bands_scanned, marker_sightings, marker_sightings_capped, marker_objects,
  // marker_ids_unclaimed, marker_cut_by_part (a tag crossing its window's or band's edge, not the
  // image's: refused, its corners guessed), marker_refused_{hamming,margin,small},
  // marker_pose_failed_<reason>;
  // since the start.
  const std::map<std::string, int64_t>& counts() const { return counts_; }
  const std::vector<MarkerClass>& classes() const { return classes_; }

 private:
  std::vector<MarkerClass> classes_;
  MarkerScanParams p_;
  cv::Size size_;
  std::unique_ptr<MarkerDetector> detectors_[2];  // one per camera: libapriltag keeps state
  int next_band_ = 0;
  std::map<std::string, int64_t> counts_;
};

}  // namespace ptz::perception
