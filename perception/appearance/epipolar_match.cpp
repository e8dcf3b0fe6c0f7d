#include "perception/appearance/epipolar_match.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "perception/detection/stereo.hpp"

namespace ptz::perception {
namespace {

// The vertex of the parabola through (-1, a), (0, b), (1, c): a peak's sub-pixel offset.
double vertex(double a, double b, double c) {
  const double d = a - 2 * b + c;
  return std::abs(d) < 1e-12 ? 0 : std::clamp(0.5 * (a - c) / d, -0.5, 0.5);
}

}  // namespace

cv::Mat greyOf(const cv::Mat& image) {
  if (image.channels() != 3) return image;
  cv::Mat g;
  cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
  return g;
}

cv::Point2d subPixelPeak(const cv::Mat& r, cv::Point loc) {
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

bool matchAlongEpipolar(const cv::Mat& patch, const Eigen::Vector2d& centre, const CameraView& from,
                        const CameraView& to, const CropPixels& to_crop, double min_range_m,
                        double max_range_m, EpipolarMatch* out, std::string* why, double reduce) {
  *out = {};
  // The patch as the other view sees it (its focal length may differ: another zoom).
  const double s = std::clamp(to.intrinsics.fx / from.intrinsics.fx, 0.25, 4.0);
  cv::Mat other_patch = patch;
  if (std::abs(s - 1) >= 0.02) {
    cv::resize(patch, other_patch,
               cv::Size(std::max(8, static_cast<int>(std::lround(patch.cols * s))),
                        std::max(8, static_cast<int>(std::lround(patch.rows * s)))),
               0, 0, s < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  }
  const Eigen::Vector3d ray = pixelRay(from, centre);
  const int half_w = other_patch.cols / 2 + 1, half_h = other_patch.rows / 2 + 1;
  std::vector<cv::Point2d> line;
  for (double r = min_range_m; r < max_range_m; r *= 1.002) {
    const Eigen::Vector2d q = to.project(from.position_head_m + r * ray);
    if (!q.allFinite() || q.x() < half_w || q.y() < half_h || q.x() > to.width - 1 - half_w ||
        q.y() > to.height - 1 - half_h) {
      continue;
    }
    if (line.empty() || std::hypot(q.x() - line.back().x, q.y() - line.back().y) >= 0.5) {
      line.emplace_back(q.x(), q.y());
    }
  }
  if (line.empty()) {
    *why = "the epipolar line is not in the other image";
    return false;
  }
  cv::Rect band = cv::boundingRect(std::vector<cv::Point>(line.begin(), line.end()));
  const int reach_x = other_patch.cols / 2 + 4, reach_y = other_patch.rows / 2 + 4;
  band = cv::Rect(band.x - reach_x, band.y - reach_y, band.width + 2 * reach_x,
                  band.height + 2 * reach_y) &
         cv::Rect(0, 0, to.width, to.height);
  // matchTemplate needs the band at least the patch's size both ways (else it swaps them).
  if (band.width < other_patch.cols || band.height < other_patch.rows) {
    *why = "the other view's patch does not fit along its epipolar line";
    return false;
  }
  cv::Mat pixels;
  if (!to_crop(band, &pixels, why)) return false;
  cv::Mat grey = greyOf(pixels), small_patch = other_patch;
  reduce = std::clamp(reduce, 0.05, 1.0);
  if (reduce < 1) {
    cv::resize(grey, grey, cv::Size(), reduce, reduce, cv::INTER_AREA);
    cv::resize(other_patch, small_patch,
               cv::Size(std::max(4, static_cast<int>(std::lround(other_patch.cols * reduce))),
                        std::max(4, static_cast<int>(std::lround(other_patch.rows * reduce)))),
               0, 0, cv::INTER_AREA);
    if (grey.cols < small_patch.cols || grey.rows < small_patch.rows) {
      *why = "the other view's patch does not fit along its epipolar line";
      return false;
    }
  }
  cv::Mat r;
  cv::matchTemplate(grey, small_patch, r, cv::TM_CCOEFF_NORMED);
  // A place of the correlation map (the patch's top-left, reduced pixels) and the image point of
  // the patch's centre there.
  const cv::Point2d half((small_patch.cols - 1) / 2.0, (small_patch.rows - 1) / 2.0);
  const double sx = static_cast<double>(grey.cols) / band.width,
               sy = static_cast<double>(grey.rows) / band.height;
  const auto toImage = [&](const cv::Point2d& at) {
    return cv::Point2d(band.x + (at.x + half.x + 0.5) / sx - 0.5,
                       band.y + (at.y + half.y + 0.5) / sy - 0.5);
  };
  // Along the line: the best place, and the best one farther than half a patch from it.
  cv::Point best_at(-1, -1);
  std::vector<std::pair<double, cv::Point>> scores;
  for (const auto& q : line) {
    const cv::Point at(static_cast<int>(std::lround((q.x - band.x + 0.5) * sx - 0.5 - half.x)),
                       static_cast<int>(std::lround((q.y - band.y + 0.5) * sy - 0.5 - half.y)));
    if (at.x < 0 || at.y < 0 || at.x >= r.cols || at.y >= r.rows) continue;
    const double v = r.at<float>(at);
    scores.emplace_back(v, at);
    if (v > out->best) out->best = v, best_at = at;
  }
  if (best_at.x < 0) {
    *why = "the epipolar line is not in the other image";
    return false;
  }
  const double apart_px = std::min(small_patch.cols, small_patch.rows) / 2.0;
  for (const auto& [v, at] : scores) {
    if (cv::norm(at - best_at) > apart_px) out->second = std::max(out->second, v);
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
  out->centre = toImage(subPixelPeak(r, peak));
  out->patch_size = other_patch.size();
  if (reduce < 1) {
    // The reduced match is as exact as the reduced pixels: refined at full resolution nearby.
    const int reach = static_cast<int>(std::ceil(1.5 / reduce)) + 1;
    const cv::Rect near =
        cv::Rect(
            static_cast<int>(std::lround(out->centre.x - (other_patch.cols - 1) / 2.0)) - reach,
            static_cast<int>(std::lround(out->centre.y - (other_patch.rows - 1) / 2.0)) - reach,
            other_patch.cols + 2 * reach, other_patch.rows + 2 * reach) &
        cv::Rect(0, 0, to.width, to.height);
    if (near.width >= other_patch.cols && near.height >= other_patch.rows) {
      cv::Mat near_pixels, fine;
      if (!to_crop(near, &near_pixels, why)) return false;
      cv::matchTemplate(greyOf(near_pixels), other_patch, fine, cv::TM_CCOEFF_NORMED);
      double fine_best = 0;
      cv::Point loc;
      cv::minMaxLoc(fine, nullptr, &fine_best, nullptr, &loc);
      out->centre = cv::Point2d(near.tl()) + subPixelPeak(fine, loc) +
                    cv::Point2d((other_patch.cols - 1) / 2.0, (other_patch.rows - 1) / 2.0);
    }
  }
  return true;
}

}  // namespace ptz::perception
