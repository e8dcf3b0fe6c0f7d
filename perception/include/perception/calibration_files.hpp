// The image-files source of ptz-calibrate: left/right pairs from a folder or a list file, read
// and searched for the board, with errors naming the files.
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "perception/calibration.hpp"

namespace ptz::perception {

struct ImagePair {
  std::string left_path, right_path;
};

// Image files of `folder` named <left_prefix>X and <right_prefix>X (same X), sorted by X. Throws
// CalibrationError naming every file without its partner, or when none match.
std::vector<ImagePair> pairsFromFolder(const std::string& folder, const std::string& left_prefix,
                                       const std::string& right_prefix);
// A text file with one "left_path right_path" per line ('#' comments); relative paths are relative
// to the list's folder.
std::vector<ImagePair> pairsFromList(const std::string& list_path);

struct DetectedViews {
  cv::Size image_size;
  std::vector<ViewPair> views;       // board found in both images
  std::vector<std::string> skipped;  // "left.jpg / right.jpg: board not found in right.jpg"
};

// Reads every image (gray) and finds the board in both, on all cores. Throws CalibrationError for
// an unreadable file, images of different sizes, or no board found anywhere.
DetectedViews detectPairs(const std::vector<ImagePair>& pairs, const BoardSpec& board);

}  // namespace ptz::perception
