// How far a camera turned or zoomed between two of its images, from the images and the rig:
// corners tracked with Lucas-Kanade (forward, then back to where they began), their 3D points from
// the stereo pair at home, and the pan and tilt, or the zoom, at which the rig's own projection
// (distortion, the optical centre off the pivot) puts them where they were seen.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "common/rig.hpp"

namespace ptz::driver {

// Strong corners of a grey image, at most max_points, 10 px apart.
std::vector<cv::Point2f> findCorners(const cv::Mat& grey, int max_points);

// Corners of `from_image` found again in `to_image`; kept when tracking back lands within
// 0.3 px of where they began. predicted: where they are expected (empty: where they were).
struct Tracks {
  std::vector<cv::Point2f> from, to;
  std::vector<int> index;  // of each kept track in the points given
};
Tracks track(const cv::Mat& from_image, const cv::Mat& to_image,
             const std::vector<cv::Point2f>& points,
             const std::vector<cv::Point2f>& predicted = {});

// How far the image moved along the tracks, px: the mean shift of the tracked corners under the
// similarity (shift, rotation, scale) that fits them, so a zoom counts as a pan does and noise
// averages out (infinite without enough tracks).
double imageMotionPx(const Tracks& t);

// What one camera saw at home (pan = tilt = 0) that the other saw too: its pixels and the points
// in the head frame (by the rays' midpoint; far points, whose depth the baseline cannot tell, at
// 200 m, where the pivot's offset makes no difference).
struct ScenePoints {
  std::vector<cv::Point2f> pixels;
  std::vector<Eigen::Vector3d> points_head_m;
};
ScenePoints triangulateAtHome(const StereoRig& rig, Side side, double zoom, const cv::Mat& left,
                              const cv::Mat& right, int max_points);

struct Fit {
  bool ok = false;
  double value[2] = {0, 0};  // pan, tilt (rad) or zoom ratio, unused
  double rms_px = 0;
  int inliers = 0;
  std::string why;
};
constexpr int kMinFitPoints = 20;

// The pan and tilt (from guess) at which side's camera, at zoom, sees points at observed.
Fit fitPanTilt(const StereoRig& rig, Side side, double zoom,
               const std::vector<Eigen::Vector3d>& points_head_m,
               const std::vector<cv::Point2f>& observed, double pan_guess_rad,
               double tilt_guess_rad);

// Where pixels seen at zoom_from appear at zoom_to (pan and tilt unchanged: the same rays).
std::vector<cv::Point2f> zoomedPixels(const StereoRig& rig, Side side, double zoom_from,
                                      double zoom_to, const std::vector<cv::Point2f>& pixels);

// The zoom (from guess) at which pixels seen at zoom_from appear at observed.
Fit fitZoom(const StereoRig& rig, Side side, double zoom_from, const std::vector<cv::Point2f>& from,
            const std::vector<cv::Point2f>& observed, double zoom_guess);

}  // namespace ptz::driver
