// The image-files source of ptz-calibrate: left/right pairs from a folder or a list file, read
// and searched for the board, with errors naming the files.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <limits>
#include <string>
#include <vector>

#include "perception/calibrate/calibration.hpp"

namespace ptz::perception {

struct ImagePair {
  std::string left_path, right_path;
  // Pan and tilt of each camera when the list gives them (NaN: unknown).
  std::array<double, 2> left_pan_tilt_rad{kUnknown, kUnknown},
      right_pan_tilt_rad{kUnknown, kUnknown};
  static constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();
};

// Image files of `folder` named <left_prefix>X and <right_prefix>X (same X), sorted by X. Throws
// CalibrationError naming every file without its partner, or when none match.
std::vector<ImagePair> pairsFromFolder(const std::string& folder, const std::string& left_prefix,
                                       const std::string& right_prefix);
// A text file with one "left_path right_path" per line, optionally followed by
// "left_pan_deg left_tilt_deg right_pan_deg right_tilt_deg" ('#' comments); relative paths are
// relative to the list's folder.
std::vector<ImagePair> pairsFromList(const std::string& list_path);

struct DetectedViews {
  cv::Size image_size;
  std::vector<ViewPair> views;  // board found in both images
  // Every image with the board, per camera (mono calibrations need no pairs).
  std::vector<std::vector<cv::Point2f>> left_px, right_px;
  std::vector<std::array<double, 2>> left_pan_tilt_rad, right_pan_tilt_rad;  // of those images
  std::vector<std::string> skipped;  // "left.jpg / right.jpg: board not found in right.jpg"
};

// Reads every image (gray) and finds the board in both, on all cores. Throws CalibrationError for
// an unreadable file, images of different sizes, or no board found anywhere.
// `progress` gets a line per image as its board search ends (from the worker threads, one at a
// time).
DetectedViews detectPairs(const std::vector<ImagePair>& pairs, const BoardSpec& board,
                          const Progress& progress = {});

}  // namespace ptz::perception
