// Where ptz-detect looks for faces and people in a frame (no LCM), and how each is ranged: the
// detectors (OpenCV's HOG people detector, cascades) run on the left image only, in a window
// around each such track (scaled so the object is just above the detector's smallest size: a few
// scales) and in one vertical strip a frame of the image scaled by the class's scan_scale (on the
// simulator's textured VGA frames, two cores, HOG costs 24 ms for the image halved and the face
// cascade 100 ms at full scale; a strip is a third to a half of that). Each
// detection's inner patch is then found along its epipolar line in the right view and
// triangulated; a detection whose size does not fit its range (a poster's face, a false hit on the
// backdrop) is refused.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/objdetect.hpp>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "perception/appearance/epipolar_match.hpp"
#include "perception/detection/windows.hpp"
#include "perception/people/people_params.hpp"
#include "perception/tracking/tracker.hpp"

namespace ptz::perception {

struct PeopleScanParams {
  int strips = 6;  // the image searched for new objects in this many strips (one class's a frame)
  double window_margin = 0.25;        // a track's window: its box grown by this on each side
  double max_window_px2 = 320 * 240;  // a window's area once scaled: larger ones left to strips
  double min_score = 0.6;             // the right view's match: normalised correlation
  double unique_margin = 0.05;        // ... beating any other place along the line
  int max_patch_px = 64;              // matched on patches reduced to this (speed)
  double size_tolerance = 0.4;        // box height within (1 +- this) of height_m at its range
  double pixel_sigma_px = 1.0;        // a detection's centre noise, for the covariance
  double min_range_m = 0.3, max_range_m = 50;
  int max_per_class = 8;  // objects a class makes a frame (the rest counted)
};

// HOG's detectMultiScale (no padding, hit threshold 0, rectangles grouped) with its levels shared
// by forBothCameras' two threads: OpenCV's own pool is off in ptz-detect (detect/new_objects.hpp).
// The same levels, hits, grouping and cut to the image as OpenCV's.
void hogMultiScale(const cv::HOGDescriptor& hog, const cv::Mat& img, cv::Size stride, double scale0,
                   int final_threshold, std::vector<cv::Rect>* found, std::vector<double>* weights);

class PeopleScanner {
 public:
  PeopleScanner(std::vector<PeopleClass> classes, PeopleScanParams params, cv::Size image);

  bool enabled() const { return !classes_.empty(); }
  // The index of a class by name (-1: none).
  int classOf(const std::string& class_name) const;
  const std::vector<PeopleClass>& classes() const { return classes_; }

  // One frame: windows around the tracks of these classes (predicted to t_s), this frame's strip
  // (the next strip a call; parts: which of the two); the objects found in the left view and
  // ranged in the right. False when a crop fails (*why).
  bool scan(const std::vector<Track>& tracks, double t_s, const CameraView& left,
            const CameraView& right, const CropPixels crop[2], std::vector<PatchObject>* out,
            std::string* why, ScanParts parts = ScanParts::kBoth);

  // people_windows, people_windows_left_to_strips, people_strips_scanned, people_boxes (the
  // detectors' hits), people_objects,
  // people_refused_{unmatched,not_unique,size,range,epipolar,capped}; since the start.
  const std::map<std::string, int64_t>& counts() const { return counts_; }

 private:
  struct Box {
    cv::Rect2d rect;  // the detector's box, image pixels
    double weight = 1;
  };
  // The detector's boxes of class c in `grey` (the image's pixels `part`, scaled by `scale`); fine:
  // HOG's windows 4 px apart (not 8), a cascade's scales 1.1 apart (not 1.2): a track's window.
  // Strongest first.
  std::vector<Box> detect(size_t c, const cv::Mat& grey, const cv::Rect& part, double scale,
                          bool fine);
  // A box ranged in the right view, as an object (false: refused, counted).
  bool range(size_t c, const cv::Rect2d& box, const CameraView& left, const CameraView& right,
             const CropPixels crop[2], PatchObject* out, std::string* why);

  std::vector<PeopleClass> classes_;
  PeopleScanParams p_;
  cv::Size size_;
  cv::HOGDescriptor hog_, window_hog_;
  std::vector<std::unique_ptr<cv::CascadeClassifier>> cascades_;  // by class (hog: none)
  int next_strip_ = 0;
  std::map<std::string, int64_t> counts_;
};

}  // namespace ptz::perception
