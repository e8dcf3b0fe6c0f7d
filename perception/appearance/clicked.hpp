// An object picked by a click (no LCM): whatever is under the pixel, with no class for it. Its
// appearance is a grey patch around the click (normalised cross-correlation, so brightness and
// contrast may change); the same patch is found in the other view along the epipolar line of the
// click, which gives the object's range; then each frame it is found in both views near the
// track's predicted image, scaled by the focal length and the range since the click, and
// triangulated. Its measurements feed the tracker as any object's, as class "clicked".
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <optional>
#include <string>

#include "common/rig.hpp"
#include "perception/appearance/epipolar_match.hpp"
#include "perception/detection/windows.hpp"
#include "perception/tracking/tracker.hpp"

namespace ptz::perception {

struct ClickedParams {
  int patch_px = 48;             // the patch's side at the click
  double min_score = 0.7;        // a frame's match in each view: normalised correlation
  double min_start_score = 0.8;  // the other view's match at the click
  double unique_margin = 0.1;    // ... beating any other along the line (beyond half a patch)
  double max_epipolar_px = 3.0;  // a frame's two matches off each other's epipolar line
  double search_margin_px = 16;  // around the predicted patch
  double pixel_sigma_px = 0.5;   // a match's noise, for the covariance
  double min_range_m = 0.3, max_range_m = 50;
};

class ClickedTracker {
 public:
  static constexpr const char* kClassName = "clicked";
  explicit ClickedTracker(ClickedParams params = {}) : p_(params) {}

  // A model of what is under `pixel` of `side`'s image, matched in the other view along its
  // epipolar line; its first object in *first. False and *why (the model is then none): the patch
  // leaves the image, the patch is flat (nothing to match), no match or two alike along the line,
  // out of range, or a crop fails.
  bool start(Side side, const Eigen::Vector2d& pixel, const CropPixels crop[2],
             const CameraView& left, const CameraView& right, PatchObject* first, std::string* why);
  bool active() const { return !patch_.empty(); }
  void stop() { patch_.release(); }

  // The object in this frame: matched in both views around where `track` (the tracker's track of
  // the model, predicted to t_s; none: where it was last found) is seen; none when either view's
  // best match is under min_score, the two are not on each other's epipolar lines, or the range is
  // out of bounds. *why says which.
  std::optional<PatchObject> find(const Track* track, double t_s, const CropPixels crop[2],
                                  const CameraView& left, const CameraView& right,
                                  std::string* why);

 private:
  // The patch scaled for a view with focal length fx at range_m.
  cv::Mat patchFor(double fx, double range_m) const;
  // The best match of `patch` in `rect` of a view (grey), its centre (sub-pixel) and score.
  bool match(const cv::Mat& patch, const cv::Rect& rect, const CropPixels& crop, cv::Size image,
             cv::Point2d* centre, double* score, std::string* why) const;
  bool triangulated(const CameraView& left, const CameraView& right, const cv::Point2d& l,
                    const cv::Point2d& r, const cv::Size& patch_size, PatchObject* out,
                    std::string* why) const;

  ClickedParams p_;
  cv::Mat patch_;             // CV_8U, at the click
  double patch_fx_ = 0;       // the clicked view's focal length
  double patch_range_m_ = 0;  // the object's range from that camera at the click
  Eigen::Vector3d last_m_ = Eigen::Vector3d::Zero();
};

}  // namespace ptz::perception
