// The pixels of a STEREO_FRAME's image as ptz-detect reads them (no LCM): only the parts it scans
// (a JPEG's rows and columns of them alone, jpeg_window.hpp), rows reduced for a pyramid full scan
// or a band, and the parts decoded once kept for a box's views. Every image is one checked by
// checkStereoFrame (and, for the reduced rows, in colour as checkFrameMatchesRig requires).
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <utility>
#include <vector>

#include "perception/detection/windows.hpp"
#include "ptzstereo/image_t.hpp"

namespace ptz::perception {

// The part `rect` of an image as BGR: a JPEG's rows and columns of it alone; the whole image
// through decodeImage (the same pixels).
bool decodeRect(const ptzstereo::image_t& m, const cv::Rect& rect, cv::Mat* out, std::string* why);

// The parts `rects` of an image as BGR: a JPEG's rows and columns of them alone, in one pass; the
// whole image through decodeImage (the same pixels).
bool decodeParts(const ptzstereo::image_t& m, const std::vector<cv::Rect>& rects,
                 std::vector<cv::Mat>* parts, std::string* why);

// Rows [row0, row1) of an image reduced by `scale` as BGR (DecodeReduced): a JPEG scaled in its
// decoder from those rows' restart segments, raw pixels area-averaged from the message's own
// bytes.
bool decodeReduced(const ptzstereo::image_t& m, int scale, int row0, int row1, cv::Mat* out,
                   std::string* why);

// One image of a frame: what WindowScanner::detect decoded of it at full resolution is kept, so
// that a box's view for its yaw is cut from it instead of decoded again (at 1080p a JPEG's second
// pass cost more than the rest of the frame). A part of a window is exactly its decode (the
// same pixels: jpeg_window.hpp). The message must outlive it.
class FramePixels {
 public:
  explicit FramePixels(const ptzstereo::image_t& m) : m_(m) {}

  // Both ways of reading the image, for WindowScanner::detect.
  ImagePixels pixels();

  // The pixels of `rect`: from a part decoded already when one holds it (*reused), else decoded.
  bool crop(const cv::Rect& rect, cv::Mat* out, bool* reused, std::string* why) const;

 private:
  const ptzstereo::image_t& m_;
  std::vector<std::pair<cv::Rect, cv::Mat>> decoded_;
};

// Both cameras' crops (CropPixels) of a frame's pixels, each from the parts decoded already where
// it can.
void cropsOf(FramePixels* left, FramePixels* right, CropPixels crops[2]);

}  // namespace ptz::perception
