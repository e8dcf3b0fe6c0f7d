#include "perception/detection/pyramid.hpp"

#include <opencv2/imgproc.hpp>

#include "perception/detection/windows.hpp"

namespace ptz::perception {

int pyramidScale(int width_px, int max_width_px) {
  if (max_width_px <= 0 || width_px <= max_width_px) return 1;
  int scale = 2;
  while (scale < 8 && (width_px + scale - 1) / scale > max_width_px) scale *= 2;
  return scale;
}

cv::Size reducedSize(const cv::Size& full, int scale) {
  return {(full.width + scale - 1) / scale, (full.height + scale - 1) / scale};
}

int pyramidMarginPx(int scale, int exact_margin_px) {
  return (scale + 1) * exact_margin_px;
}

std::vector<cv::Rect> pyramidWindows(const std::vector<Region>& candidates, int scale,
                                     int margin_px, const cv::Size& image) {
  std::vector<cv::Rect> windows;
  for (const Region& c : candidates) {
    const cv::Rect w(c.bbox.x * scale - margin_px, c.bbox.y * scale - margin_px,
                     c.bbox.width * scale + 2 * margin_px, c.bbox.height * scale + 2 * margin_px);
    const cv::Rect in_image = w & cv::Rect({0, 0}, image);
    if (!in_image.empty()) windows.push_back(in_image);
  }
  return mergeRects(windows);
}

bool WindowScanner::pyramidSide(const Detector& detector, int scale, const ImagePixels& pixels,
                                std::vector<Region>* regions, std::string* fallback, int* grown,
                                std::string* why) const {
  fallback->clear();
  const cv::Size small = reducedSize(size_, scale);
  cv::Mat reduced;
  if (pixels.reduced) {
    if (!pixels.reduced(scale, 0, size_.height, &reduced, why)) return false;
  } else {
    std::vector<cv::Mat> image;
    if (!pixels.parts({cv::Rect({0, 0}, size_)}, &image, why)) return false;
    if (image.size() != 1 || image[0].size() != size_ || image[0].type() != CV_8UC3) {
      *why = "the image is not the frame's size or BGR";
      return false;
    }
    cv::resize(image[0], reduced, small, 0, 0, cv::INTER_AREA);
  }
  if (reduced.size() != small || reduced.type() != CV_8UC3) {
    *why = "the reduced image is not the reduced size or BGR";
    return false;
  }
  std::vector<cv::Rect> windows = pyramidWindows(detector.detectReduced(reduced, scale), scale,
                                                 pyramidMarginPx(scale, margin_px_), size_);
  // Windows over much of the image: a full-resolution scan costs about as much, and is simpler.
  if (!refuse(windows).empty()) {
    *fallback = "cover";
    return true;
  }
  bool cut = false;
  if (!detectSide(detector, windows, pixels.parts, regions, &cut, why)) return false;
  if (!cut) return true;
  // A region reaching beyond what the reduced image showed (a thin part the reduced filters
  // removed): grown once, as a track's window; still cut, the image is scanned whole.
  ++*grown;
  windows = grow(windows);
  if (refuse(windows).empty()) {
    if (!detectSide(detector, windows, pixels.parts, regions, &cut, why)) return false;
    if (!cut) return true;
  }
  *fallback = "cut";
  return true;
}

}  // namespace ptz::perception
