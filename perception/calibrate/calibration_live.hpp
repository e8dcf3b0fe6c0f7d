// Collecting views from a live stream (no LCM here): a view is kept only when the board is found
// in both images and it adds coverage of position, size and skew, as ROS camera_calibration does.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <string>
#include <vector>

#include "perception/calibrate/calibration.hpp"

namespace ptz::perception {

// Where and how the board sits in an image, each in 0..1 (ROS camera_calibration's measures):
// x, y of the board's centre within the room it has, size = sqrt(board area / image area),
// skew = how far the board's corner angle is from 90 deg (x2, clamped).
struct ViewCoverage {
  double x = 0, y = 0, size = 0, skew = 0;
};
ViewCoverage coverageOf(const std::vector<cv::Point2f>& corners_px, const BoardSpec& board,
                        cv::Size image_size);

class LiveCollector {
 public:
  // min_distance: the L1 distance in (x, y, size, skew) a new view needs from every kept one.
  LiveCollector(BoardSpec board, double min_distance = 0.2);

  enum class Result { kKept, kNoBoard, kNotBothImages, kNoNewCoverage, kOtherSize };
  // Looks for the board in both images; keeps the view when it adds coverage. `name` labels the
  // view in reports (e.g. "frame 123").
  Result offer(const cv::Mat& left, const cv::Mat& right, const std::string& name);

  const std::vector<ViewPair>& views() const { return views_; }
  cv::Size imageSize() const { return image_size_; }
  // Range covered of x, y, size, skew against what a good set spans (ROS: 0.7, 0.7, 0.4, 0.5),
  // each 0..1.
  std::array<double, 4> progress() const;
  std::string progressText() const;

 private:
  BoardSpec board_;
  double min_distance_;
  cv::Size image_size_;
  std::vector<ViewPair> views_;
  std::vector<ViewCoverage> coverage_;
};

// "kept", "no_board", ...: the status counters are frames_<name>.
const char* resultName(LiveCollector::Result result);

}  // namespace ptz::perception
