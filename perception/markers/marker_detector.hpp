// Fiducial markers in one image (no LCM): libapriltag's detector for AprilTag families, OpenCV
// contrib's ArUco for the others (or for AprilTag families when a class asks for it). Each tag's
// four outer corners in the order of MarkerClass::corners (top-left, top-right, bottom-right,
// bottom-left as printed), sub-pixel, in full-image (distorted) coordinates.
// Not thread-safe (libapriltag's detector keeps state): one per camera.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "perception/markers/marker_params.hpp"

namespace ptz::perception {

struct MarkerSighting {
  int class_index = -1;  // into the detector's classes
  int id = -1;
  std::array<cv::Point2d, 4> corners_px;
  cv::Point2d centre_px;       // the intersection of the diagonals
  double decision_margin = 0;  // libapriltag's (ArUco: 0)
  int hamming = 0;             // bits corrected (libapriltag)
  // The bounding box of the corners, rounded out.
  cv::Rect bbox() const;
};

struct MarkerDetectorParams {
  // libapriltag: the quads are found on the image reduced by this (1: full resolution; the
  // corners are then refined on the full image), with this many threads.
  double apriltag_decimate = 2;
  int apriltag_threads = 1;
  // Sightings with more corrected bits than this are refused (false positives grow with it).
  int max_hamming = 1;
  double min_decision_margin = 20;
  // Tags whose edge is shorter than this in the image are refused (their corners are noise).
  double min_edge_px = 8;
};

class MarkerDetector {
 public:
  MarkerDetector(std::vector<MarkerClass> classes, MarkerDetectorParams params = {});
  ~MarkerDetector();
  MarkerDetector(const MarkerDetector&) = delete;
  MarkerDetector& operator=(const MarkerDetector&) = delete;

  // The tags of the classes in an 8-bit grey or BGR part of an image whose top-left pixel is
  // `offset` in the full image; an id no class takes is left out (counted in *unclaimed).
  // decimate > 0: libapriltag's quad_decimate for this call (else the params'), and ArUco's image
  // reduced by it. only_class >= 0: that class's detector and family alone.
  std::vector<MarkerSighting> detect(const cv::Mat& image, const cv::Point& offset,
                                     int* unclaimed = nullptr, double decimate = 0,
                                     int only_class = -1);
  const std::vector<MarkerClass>& classes() const { return classes_; }
  // Tags refused since the start: more bits corrected than max_hamming, a decision margin under
  // min_decision_margin, an edge under min_edge_px.
  int64_t refusedHamming() const { return refused_hamming_; }
  int64_t refusedMargin() const { return refused_margin_; }
  int64_t refusedSmall() const { return refused_small_; }

 private:
  struct AprilTag;
  struct Aruco;
  std::vector<MarkerClass> classes_;
  MarkerDetectorParams params_;
  std::vector<std::unique_ptr<AprilTag>> apriltags_;  // one per family
  std::vector<std::unique_ptr<Aruco>> arucos_;        // one per family
  int64_t refused_hamming_ = 0, refused_margin_ = 0, refused_small_ = 0;
};

}  // namespace ptz::perception
