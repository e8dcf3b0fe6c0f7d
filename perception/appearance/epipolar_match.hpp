// A patch of one view found in the other (no LCM): along the epipolar line of its centre, pixel by
// pixel from near to far, by normalised cross-correlation (brightness and contrast may differ
// between the cameras). The best place, and the best one farther than half a patch from it, so a
// caller can refuse a match that is not unique. Used to start a clicked object's model and to
// range each face or person a detector finds in the left view.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>

#include "common/rig.hpp"
#include "perception/detection/windows.hpp"

namespace ptz::perception {

// An object seen as a patch in both views and triangulated.
struct PatchObject {
  std::string class_name;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // head frame
  Eigen::Matrix3d covariance_m2 = Eigen::Matrix3d::Zero();
  double radius_m = 0;
  cv::Point2d pixel[2];  // each view's centre, distorted image coordinates
  cv::Rect box[2];       // each view's patch (or the detector's box)
  double score[2] = {0, 0};
};

struct EpipolarMatch {
  cv::Point2d centre;   // in the other view, sub-pixel
  cv::Size patch_size;  // the patch as the other view sees it (scaled by the focal lengths)
  double best = -2, second = -2;  // correlations: the best place's, the best elsewhere's
};

// The patch (grey) centred at `centre` (pixel coordinates) of view `from`, looked for in view `to`
// (its pixels by to_crop) between ranges min_range_m and max_range_m of `from`'s ray; on both
// reduced by `reduce` (<= 1: a large patch costs less, its match is as exact as the reduced
// pixels). False and *why when the line misses the other image, the patch does not fit along it,
// or a crop fails.
bool matchAlongEpipolar(const cv::Mat& patch, const Eigen::Vector2d& centre, const CameraView& from,
                        const CameraView& to, const CropPixels& to_crop, double min_range_m,
                        double max_range_m, EpipolarMatch* out, std::string* why,
                        double reduce = 1);

// The grey image of a BGR one (a grey one as it is).
cv::Mat greyOf(const cv::Mat& image);

// The peak of a correlation map at loc, refined to a fraction of a pixel.
cv::Point2d subPixelPeak(const cv::Mat& correlation, cv::Point loc);

}  // namespace ptz::perception
