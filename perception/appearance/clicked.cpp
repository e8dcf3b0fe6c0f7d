#include "perception/appearance/clicked.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <vector>

#include "perception/detection/stereo.hpp"

namespace ptz::perception {
namespace {

cv::Mat grey(const cv::Mat& bgr) {
  cv::Mat g;
  if (bgr.channels() == 3) {
    cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  } else {
    g = bgr;
  }
  return g;
}

// The vertex of the parabola through (-1, a), (0, b), (1, c): a peak's sub-pixel offset.
double vertex(double a, double b, double c) {
  const double d = a - 2 * b + c;
  return std::abs(d) < 1e-12 ? 0 : std::clamp(0.5 * (a - c) / d, -0.5, 0.5);
}

// The peak of a correlation map at loc, refined to a fraction of a pixel.
cv::Point2d subPixel(const cv::Mat& r, cv::Point loc) {
  double dx = 0, dy = 0;
  if (loc.x > 0 && loc.x + 1 < r.cols) {
    dx = vertex(r.at<float>(loc.y, loc.x - 1), r.at<float>(loc.y, loc.x),
                r.at<float>(loc.y, loc.x + 1));
  }
  if (loc.y > 0 && loc.y + 1 < r.rows) {
    dy = vertex(r.at<float>(loc.y - 1, loc.x), r.at<float>(loc.y, loc.x),
                r.at<float>(loc.y + 1, loc.x));
  }
  return {loc.x + dx, loc.y + dy};
}

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
  cv::matchTemplate(grey(pixels), patch, r, cv::TM_CCOEFF_NORMED);
  double best = 0;
  cv::Point loc;
  cv::minMaxLoc(r, nullptr, &best, nullptr, &loc);
  *score = best;
  *centre = cv::Point2d(rect.tl()) + subPixel(r, loc) +
            cv::Point2d((patch.cols - 1) / 2.0, (patch.rows - 1) / 2.0);
  return true;
}

bool ClickedTracker::triangulated(const CameraView& left, const CameraView& right,
                                  const cv::Point2d& l, const cv::Point2d& r,
                                  const cv::Size& patch_size, ClickedObject* out,
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
  out->position_m = p;
  out->covariance_m2 = triangulationCovariance(left, right, lp, rp, p_.pixel_sigma_px);
  out->radius_m = patch_size.width / 2.0 * range_m / left.intrinsics.fx;
  out->pixel[0] = l;
  out->pixel[1] = r;
  return true;
}

bool ClickedTracker::start(Side side, const Eigen::Vector2d& pixel, const CropPixels crop[2],
                           const CameraView& left, const CameraView& right, ClickedObject* first,
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
  const cv::Mat patch = grey(pixels).clone();
  cv::Scalar mean, stddev;
  cv::meanStdDev(patch, mean, stddev);
  if (stddev[0] < 4) {
    *why = "nothing to see under the click (a flat patch)";
    return false;
  }
  // The click's ray through the other view, pixel by pixel from near to far.
  const Eigen::Vector2d centre(rect.x + (rect.width - 1) / 2.0, rect.y + (rect.height - 1) / 2.0);
  const Eigen::Vector3d ray = pixelRay(cv_, centre);
  // The patch as the other view sees it (its focal length may differ: another zoom).
  patch_ = patch;
  patch_fx_ = cv_.intrinsics.fx;
  patch_range_m_ = 1;  // no range yet: scaled by the focal lengths alone
  const cv::Mat other_patch = patchFor(ov.intrinsics.fx, 1);
  const int other_half = other_patch.cols / 2 + 1;
  std::vector<cv::Point2d> line;
  for (double r = p_.min_range_m; r < p_.max_range_m; r *= 1.002) {
    const Eigen::Vector2d q = ov.project(cv_.position_head_m + r * ray);
    if (!q.allFinite() || q.x() < other_half || q.y() < other_half ||
        q.x() > ov.width - 1 - other_half || q.y() > ov.height - 1 - other_half) {
      continue;
    }
    if (line.empty() || std::hypot(q.x() - line.back().x, q.y() - line.back().y) >= 0.5) {
      line.emplace_back(q.x(), q.y());
    }
  }
  if (line.empty()) {
    stop();
    *why = "the click's epipolar line is not in the other image";
    return false;
  }
  cv::Rect band = cv::boundingRect(std::vector<cv::Point>(line.begin(), line.end()));
  const int reach = other_patch.cols / 2 + 4;
  band = cv::Rect(band.x - reach, band.y - reach, band.width + 2 * reach, band.height + 2 * reach) &
         cv::Rect(0, 0, ov.width, ov.height);
  // matchTemplate needs the band at least the patch's size both ways (else it swaps them).
  if (band.width < other_patch.cols || band.height < other_patch.rows) {
    stop();
    *why = "the other view's patch does not fit along its epipolar line";
    return false;
  }
  cv::Mat other_pixels;
  if (!crop[o](band, &other_pixels, why)) {
    stop();
    return false;
  }
  cv::Mat r;
  cv::matchTemplate(grey(other_pixels), other_patch, r, cv::TM_CCOEFF_NORMED);
  const cv::Point2d offset = cv::Point2d(band.tl()) + cv::Point2d((other_patch.cols - 1) / 2.0,
                                                                  (other_patch.rows - 1) / 2.0);
  // Along the line: the best place, and the best one farther than half a patch from it.
  double best = -2, second = -2;
  cv::Point best_at(-1, -1);
  std::vector<std::pair<double, cv::Point>> scores;
  for (const auto& q : line) {
    const cv::Point at(static_cast<int>(std::lround(q.x - offset.x)),
                       static_cast<int>(std::lround(q.y - offset.y)));
    if (at.x < 0 || at.y < 0 || at.x >= r.cols || at.y >= r.rows) continue;
    const double v = r.at<float>(at);
    scores.emplace_back(v, at);
    if (v > best) best = v, best_at = at;
  }
  for (const auto& [v, at] : scores) {
    if (cv::norm(at - best_at) > half) second = std::max(second, v);
  }
  if (best < p_.min_start_score) {
    stop();
    *why = "not found in the other view (best correlation " + std::to_string(best) + ")";
    return false;
  }
  if (best - second < p_.unique_margin) {
    stop();
    *why = "two places alike along the other view's epipolar line (" + std::to_string(best) + ", " +
           std::to_string(second) + ")";
    return false;
  }
  // The peak near the line's best, in both directions (the line is drawn to half a pixel).
  cv::Point peak = best_at;
  for (int dy = -2; dy <= 2; ++dy) {
    for (int dx = -2; dx <= 2; ++dx) {
      const cv::Point at = best_at + cv::Point(dx, dy);
      if (at.x >= 0 && at.y >= 0 && at.x < r.cols && at.y < r.rows &&
          r.at<float>(at) > r.at<float>(peak)) {
        peak = at;
      }
    }
  }
  const cv::Point2d other_centre = offset + subPixel(r, peak);
  const cv::Point2d click_centre(centre.x(), centre.y());
  ClickedObject obj;
  const cv::Point2d& l = side == Side::kLeft ? click_centre : other_centre;
  const cv::Point2d& rr = side == Side::kLeft ? other_centre : click_centre;
  if (!triangulated(left, right, l, rr, patch.size(), &obj, why)) {
    stop();
    return false;
  }
  obj.score[s] = 1;
  obj.score[o] = best;
  obj.box[s] = rect;
  obj.box[o] =
      cv::Rect(static_cast<int>(std::lround(other_centre.x - (other_patch.cols - 1) / 2.0)),
               static_cast<int>(std::lround(other_centre.y - (other_patch.rows - 1) / 2.0)),
               other_patch.cols, other_patch.rows);
  patch_range_m_ = (obj.position_m - cv_.position_head_m).norm();
  last_m_ = obj.position_m;
  *first = obj;
  return true;
}

std::optional<ClickedObject> ClickedTracker::find(const Track* track, double t_s,
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
  ClickedObject obj;
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
