#include "perception/calibrate/calibration_live.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ptz::perception {

namespace {

double angleDeg(cv::Point2f a, cv::Point2f b, cv::Point2f c) {  // at b
  const cv::Point2f u = a - b, v = c - b;
  return std::acos(std::clamp(u.dot(v) / (cv::norm(u) * cv::norm(v)), -1.0, 1.0)) * 180 / M_PI;
}

}  // namespace

ViewCoverage coverageOf(const std::vector<cv::Point2f>& c, const BoardSpec& board,
                        cv::Size image_size) {
  const size_t cols = static_cast<size_t>(board.inner_cols);
  const cv::Point2f up_left = c.front(), up_right = c[cols - 1], down_right = c.back(),
                    down_left = c[c.size() - cols];
  const std::vector<cv::Point2f> quad = {up_left, up_right, down_right, down_left};
  const double area = cv::contourArea(quad);
  const double border = std::sqrt(area);
  cv::Scalar mean = cv::mean(c);
  const double w = image_size.width, h = image_size.height;
  ViewCoverage v;
  v.x = std::clamp((mean[0] - border / 2) / std::max(1.0, w - border), 0.0, 1.0);
  v.y = std::clamp((mean[1] - border / 2) / std::max(1.0, h - border), 0.0, 1.0);
  v.size = std::sqrt(area / (w * h));
  v.skew = std::min(1.0, 2 * std::abs(90 - angleDeg(up_left, up_right, down_right)) * M_PI / 180);
  return v;
}

LiveCollector::LiveCollector(BoardSpec board, double min_distance)
    : board_(board), min_distance_(min_distance) {}

LiveCollector::Result LiveCollector::offer(const cv::Mat& left, const cv::Mat& right,
                                           const std::string& name) {
  if (!views_.empty() && (left.size() != image_size_ || right.size() != image_size_)) {
    return Result::kOtherSize;
  }
  ViewPair v{name + " left", name + " right", {}, {}};
  const bool in_left = findCorners(left, board_, &v.left_px);
  // The right image only when the left one has the board: most frames of a live stream do not.
  const bool in_right = in_left && findCorners(right, board_, &v.right_px);
  if (!in_left) return Result::kNoBoard;
  if (!in_right) return Result::kNotBothImages;
  const ViewCoverage c = coverageOf(v.left_px, board_, left.size());
  for (const auto& k : coverage_) {
    const double d = std::abs(c.x - k.x) + std::abs(c.y - k.y) + std::abs(c.size - k.size) +
                     std::abs(c.skew - k.skew);
    if (d <= min_distance_) return Result::kNoNewCoverage;
  }
  alignCornerOrder(v.left_px, &v.right_px);
  image_size_ = left.size();
  views_.push_back(v);
  coverage_.push_back(c);
  return Result::kKept;
}

std::array<double, 4> LiveCollector::progress() const {
  const std::array<double, 4> wanted = {0.7, 0.7, 0.4, 0.5};
  std::array<double, 4> out{};
  if (coverage_.empty()) return out;
  for (size_t i = 0; i < 4; ++i) {
    auto value = [i](const ViewCoverage& c) {
      return std::array<double, 4>{c.x, c.y, c.size, c.skew}[i];
    };
    const auto [lo, hi] = std::minmax_element(
        coverage_.begin(), coverage_.end(),
        [&](const ViewCoverage& a, const ViewCoverage& b) { return value(a) < value(b); });
    out[i] = std::min(1.0, (value(*hi) - value(*lo)) / wanted[i]);
  }
  return out;
}

std::string LiveCollector::progressText() const {
  const auto p = progress();
  char text[128];
  std::snprintf(text, sizeof text, "x %3.0f%%  y %3.0f%%  size %3.0f%%  skew %3.0f%%", 100 * p[0],
                100 * p[1], 100 * p[2], 100 * p[3]);
  return text;
}

const char* resultName(LiveCollector::Result result) {
  switch (result) {
    case LiveCollector::Result::kKept:
      return "kept";
    case LiveCollector::Result::kNoBoard:
      return "no_board";
    case LiveCollector::Result::kNotBothImages:
      return "board_left_only";
    case LiveCollector::Result::kNoNewCoverage:
      return "no_new_coverage";
    case LiveCollector::Result::kOtherSize:
      return "image_size_changed";
  }
  return "?";
}

}  // namespace ptz::perception
