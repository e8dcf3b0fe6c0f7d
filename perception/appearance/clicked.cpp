#include "perception/appearance/clicked.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <vector>

#include "perception/detection/stereo.hpp"

namespace ptz::perception {
namespace {

const CameraView& viewOf(Side s, const CameraView& left, const CameraView& right) {
  return s == Side::kLeft ? left : right;
}

}  // namespace

cv::Mat ClickedTracker::patchFor(double fx, double range_m) const {
  const double s = std::clamp(fx / patch_fx_ * patch_range_m_ / std::max(range_m, 1e-3), 0.25, 4.0);
  if (std::abs(s - 1) < 0.02) return patch_;
  const int side = std::max(8, static_cast<int>(std::lround(patch_.cols * s)));
  cv::Mat scaled;
  cv::resize(patch_, scaled, cv::Size(side, side), 0, 0, s < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  return scaled;
}

bool ClickedTracker::match(const cv::Mat& patch, const cv::Rect& wanted, const CropPixels& crop,
                           cv::Size image, cv::Point2d* centre, double* score,
                           std::string* why) const {
  const cv::Rect rect = wanted & cv::Rect(0, 0, image.width, image.height);
  if (rect.width < patch.cols || rect.height < patch.rows) {
    *why = "the search leaves the image";
    return false;
  }
  cv::Mat pixels;
  if (!crop(rect, &pixels, why)) return false;
  cv::Mat r;
  cv::matchTemplate(greyOf(pixels), patch, r, cv::TM_CCOEFF_NORMED);
  double best = 0;
  cv::Point loc;
  cv::minMaxLoc(r, nullptr, &best, nullptr, &loc);
  *score = best;
  *centre = cv::Point2d(rect.tl()) + subPixelPeak(r, loc) +
            cv::Point2d((patch.cols - 1) / 2.0, (patch.rows - 1) / 2.0);
  return true;
}

bool ClickedTracker::triangulated(const CameraView& left, const CameraView& right,
                                  const cv::Point2d& l, const cv::Point2d& r,
                                  const cv::Size& patch_size, PatchObject* out,
                                  std::string* why) const {
  const Eigen::Vector2d lp(l.x, l.y), rp(r.x, r.y);
  double epipolar_px = 0;
  Eigen::Vector3d p;
  if (!triangulate(left, right, lp, rp, &p, &epipolar_px)) {
    *why = "the matches' rays do not meet in front of both cameras";
    return false;
  }
  if (epipolar_px > p_.max_epipolar_px) {
    *why = "the matches are " + std::to_string(epipolar_px) + " px off each other's epipolar line";
    return false;
  }
  const double range_m = (p - left.position_head_m).norm();
  if (range_m < p_.min_range_m || range_m > p_.max_range_m) {
    *why = "out of range (" + std::to_string(range_m) + " m)";
    return false;
  }
  out->class_name = kClassName;
  out->position_m = p;
  out->covariance_m2 = triangulationCovariance(left, right, lp, rp, p_.pixel_sigma_px);
  out->radius_m = patch_size.width / 2.0 * range_m / left.intrinsics.fx;
  out->pixel[0] = l;
  out->pixel[1] = r;
  return true;
}

bool ClickedTracker::start(Side side, const Eigen::Vector2d& pixel, const CropPixels crop[2],
                           const CameraView& left, const CameraView& right, PatchObject* first,
                           std::string* why) {
  stop();
  const CameraView& cv_ = viewOf(side, left, right);
  const Side other = side == Side::kLeft ? Side::kRight : Side::kLeft;
  const CameraView& ov = viewOf(other, left, right);
  const int s = side == Side::kLeft ? 0 : 1, o = 1 - s;
  const int half = p_.patch_px / 2;
  const cv::Rect rect(static_cast<int>(std::lround(pixel.x())) - half,
                      static_cast<int>(std::lround(pixel.y())) - half, p_.patch_px, p_.patch_px);
  if (!pixel.allFinite() || (rect & cv::Rect(0, 0, cv_.width, cv_.height)) != rect) {
    *why = "the patch around the click leaves the image";
    return false;
  }
  cv::Mat pixels;
  if (!crop[s](rect, &pixels, why)) return false;
  const cv::Mat patch = greyOf(pixels).clone();
  cv::Scalar mean, stddev;
  cv::meanStdDev(patch, mean, stddev);
  if (stddev[0] < 4) {
    *why = "nothing to see under the click (a flat patch)";
    return false;
  }
  const Eigen::Vector2d centre(rect.x + (rect.width - 1) / 2.0, rect.y + (rect.height - 1) / 2.0);
  EpipolarMatch found;
  if (!matchAlongEpipolar(patch, centre, cv_, ov, crop[o], p_.min_range_m, p_.max_range_m, &found,
                          why)) {
    return false;
  }
  if (found.best < p_.min_start_score) {
    *why = "not found in the other view (best correlation " + std::to_string(found.best) + ")";
    return false;
  }
  if (found.best - found.second < p_.unique_margin) {
    *why = "two places alike along the other view's epipolar line (" + std::to_string(found.best) +
           ", " + std::to_string(found.second) + ")";
    return false;
  }
  const cv::Point2d other_centre = found.centre;
  const cv::Point2d click_centre(centre.x(), centre.y());
  PatchObject obj;
  const cv::Point2d& l = side == Side::kLeft ? click_centre : other_centre;
  const cv::Point2d& rr = side == Side::kLeft ? other_centre : click_centre;
  if (!triangulated(left, right, l, rr, patch.size(), &obj, why)) {
    stop();
    return false;
  }
  obj.score[s] = 1;
  obj.score[o] = found.best;
  obj.box[s] = rect;
  obj.box[o] =
      cv::Rect(static_cast<int>(std::lround(other_centre.x - (found.patch_size.width - 1) / 2.0)),
               static_cast<int>(std::lround(other_centre.y - (found.patch_size.height - 1) / 2.0)),
               found.patch_size.width, found.patch_size.height);
  patch_ = patch;
  patch_fx_ = cv_.intrinsics.fx;
  patch_range_m_ = (obj.position_m - cv_.position_head_m).norm();
  last_m_ = obj.position_m;
  *first = obj;
  return true;
}

std::optional<PatchObject> ClickedTracker::find(const Track* track, double t_s,
                                                const CropPixels crop[2], const CameraView& left,
                                                const CameraView& right, std::string* why) {
  if (!active()) {
    *why = "no model";
    return std::nullopt;
  }
  const Eigen::Vector3d predicted = track ? track->positionAt(t_s) : last_m_;
  // The prediction's spread, the larger axis: how far around its image to look.
  double sigma_m = 0;
  if (track) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(track->positionCovariance());
    sigma_m = std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
  }
  const CameraView* views[2] = {&left, &right};
  PatchObject obj;
  cv::Point2d at[2];
  cv::Size patch_size;
  for (int s = 0; s < 2; ++s) {
    const CameraView& v = *views[s];
    const double range_m = (predicted - v.position_head_m).norm();
    const cv::Mat patch = patchFor(v.intrinsics.fx, range_m);
    if (s == 0) patch_size = patch.size();
    const Eigen::Vector2d q = v.project(predicted);
    if (!q.allFinite() || std::abs(q.x()) > 1e5 || std::abs(q.y()) > 1e5) {
      *why = "its prediction is behind a camera";
      return std::nullopt;
    }
    const double reach = patch.cols / 2.0 + p_.search_margin_px +
                         std::min(3 * v.intrinsics.fx * sigma_m / std::max(range_m, 1e-3), 400.0);
    const cv::Rect rect(
        static_cast<int>(std::floor(q.x() - reach)), static_cast<int>(std::floor(q.y() - reach)),
        static_cast<int>(std::ceil(2 * reach)) + 1, static_cast<int>(std::ceil(2 * reach)) + 1);
    if (!match(patch, rect, crop[s], {v.width, v.height}, &at[s], &obj.score[s], why)) {
      return std::nullopt;
    }
    if (obj.score[s] < p_.min_score) {
      *why = std::string(s == 0 ? "left" : "right") + " view: best correlation " +
             std::to_string(obj.score[s]);
      return std::nullopt;
    }
    obj.box[s] = cv::Rect(static_cast<int>(std::lround(at[s].x - (patch.cols - 1) / 2.0)),
                          static_cast<int>(std::lround(at[s].y - (patch.rows - 1) / 2.0)),
                          patch.cols, patch.rows);
  }
  if (!triangulated(left, right, at[0], at[1], patch_size, &obj, why)) return std::nullopt;
  last_m_ = obj.position_m;
  return obj;
}

}  // namespace ptz::perception
