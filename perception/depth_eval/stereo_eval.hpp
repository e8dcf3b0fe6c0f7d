// Scoring a disparity map against Middlebury ground truth, as OpenCV's own stereo tests do:
// a pixel is bad when |d - gt| > 1 px, a 10 px border is ignored, unknown ground truth (0) is
// skipped and a pixel the matcher left invalid counts as bad.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace ptz::perception {

struct StereoScore {
  double bad_all = 0;     // over all known pixels
  double bad_nonocc = 0;  // over known, non-occluded pixels
  double invalid_fraction = 0;
  int64_t known_px = 0;
  int64_t nonocc_px = 0;
};

// Ground truth in px (CV_32F, 0 = unknown) from a Middlebury PNG/PGM and its scale; throws
// ConfigError naming the file.
cv::Mat loadGroundTruth(const std::string& path, double scale);

// Pixels of the left view also seen by the right camera (CV_8U, 255). With the right view's
// ground truth: left-right consistency within 1 px. Without: the left ground truth warped to
// the right view, where a pixel is hidden when a nearer one (larger disparity) lands on it.
cv::Mat nonOccludedMask(const cv::Mat& gt_left_px, const cv::Mat& gt_right_px);

// disparity_px: CV_32F, NaN where the matcher found none.
StereoScore scoreDisparity(const cv::Mat& disparity_px, const cv::Mat& gt_px,
                           const cv::Mat& nonocc_mask, int border_px = 10,
                           double bad_threshold_px = 1.0);

// A matcher's CV_16S disparity (1/16 px) in px, NaN below min_disparity_px.
cv::Mat disparityToFloat(const cv::Mat& disparity_16s, int min_disparity_px);

}  // namespace ptz::perception
