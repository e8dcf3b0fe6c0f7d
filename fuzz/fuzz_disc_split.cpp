// Splitting blobs into discs (perception/detection/disc_split.hpp) on masks made from the input:
// the first two bytes give the size (8 .. 135 px a side), the rest the pixels, a bit each
// (repeated to fill). Every outer contour of the mask is split. Properties: each disc is finite,
// of a radius within half the blob's shorter side, centred within a radius of its box, its arc
// share and rms in range; the discs explain at least the share asked (or there are none); the same
// blob gives the same discs.
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

#include "fuzz/fuzz_support.hpp"
#include "perception/detection/disc_split.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 3) return 0;
  const int width = 8 + data[0] % 128, height = 8 + data[1] % 128;
  cv::Mat mask(height, width, CV_8U, cv::Scalar(0));
  const size_t bits = (size - 2) * 8;
  for (int i = 0; i < width * height; ++i) {
    const size_t b = static_cast<size_t>(i) % bits;
    if (data[2 + b / 8] & (1u << (b % 8))) mask.at<uchar>(i / width, i % width) = 255;
  }
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  const ptz::perception::DiscSplitParams params;
  for (const auto& contour : contours) {
    const cv::Rect box = cv::boundingRect(contour);
    cv::Mat alone(box.size(), CV_8U, cv::Scalar(0));
    cv::drawContours(alone, std::vector<std::vector<cv::Point>>{contour}, 0, cv::Scalar(255),
                     cv::FILLED, cv::LINE_8, cv::noArray(), INT_MAX, -box.tl());
    alone &= mask(box);
    double covered = -1;
    const auto discs = ptz::perception::splitDiscs(contour, alone, box.tl(), 2.0, params, &covered);
    FUZZ_CHECK(discs.size() <= static_cast<size_t>(params.max_discs), "too many discs");
    if (!discs.empty()) {
      FUZZ_CHECK(covered >= params.min_covered && covered <= 1, std::to_string(covered));
    }
    const double largest = 1.1 * std::min(box.width, box.height) / 2.0 + 2;
    for (const auto& d : discs) {
      FUZZ_CHECK(std::isfinite(d.centre_px.x) && std::isfinite(d.centre_px.y) &&
                     std::isfinite(d.radius_px),
                 "not finite");
      FUZZ_CHECK(d.radius_px >= 2.0 && d.radius_px <= largest, std::to_string(d.radius_px));
      FUZZ_CHECK(d.centre_px.x >= box.x - d.radius_px && d.centre_px.y >= box.y - d.radius_px &&
                     d.centre_px.x <= box.br().x + d.radius_px &&
                     d.centre_px.y <= box.br().y + d.radius_px,
                 "centre far outside the blob");
      FUZZ_CHECK(d.arc_fraction >= params.min_arc_fraction && d.arc_fraction <= 1,
                 std::to_string(d.arc_fraction));
      FUZZ_CHECK(d.rms_px >= 0 && std::isfinite(d.rms_px), std::to_string(d.rms_px));
    }
    const auto again = ptz::perception::splitDiscs(contour, alone, box.tl(), 2.0, params);
    FUZZ_CHECK(again.size() == discs.size(), "not the same discs twice");
    for (size_t i = 0; i < discs.size(); ++i) {
      FUZZ_CHECK(
          again[i].centre_px == discs[i].centre_px && again[i].radius_px == discs[i].radius_px,
          "not the same discs twice");
    }
  }
  return 0;
}
