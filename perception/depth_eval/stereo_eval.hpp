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

// Ground truth in px (CV_32F, 0 = unknown): the file's value / scale. scale 0: the format's own
// unit, 1 for 8-bit PNG/PGM (Middlebury 2001-2006 need theirs: 4, 8, 16) and PFM (Middlebury
// 2014, px, inf = unknown; rows bottom to top, the scale's sign the byte order), 256 for 16-bit
// PNG (KITTI). 0, and in a PFM anything not a finite positive number, is unknown. The header of
// a PNG, PGM or PFM is read first and checked (PFM: against the file's size) and against
// `expected` (the left image's size, when not empty) before anything is decoded. *format (when
// given): "16-bit PNG, scale 256". Throws ConfigError naming the file.
cv::Mat loadGroundTruth(const std::string& path, double scale, cv::Size expected = {},
                        std::string* format = nullptr);

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
