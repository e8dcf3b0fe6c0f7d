// Decoding only a part of a JPEG (libjpeg-turbo's jpeg_crop_scanline and jpeg_skip_scanlines):
// with a window around a tracked object ptz-detect needs a few rows and columns, not the frame.
// The header is checked against the size the message claims before anything is allocated.
#pragma once

#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ptz::perception {

// The pixels of `rect` (full-image coordinates, inside width x height) of a colour JPEG that must
// be width x height with 3 components, as 8-bit BGR (as cv::imdecode gives them: the same pixels
// as the same part of a full decode). False and why for anything else; *out is then untouched.
bool decodeJpegWindow(const uint8_t* data, size_t size, int width, int height, const cv::Rect& rect,
                      cv::Mat* out, std::string* why);
// Several parts in one pass: the rows of each (those between skipped, entropy-decoded only) and
// the columns of all; (*outs)[i] the pixels of rects[i]. The same checks; *outs untouched when
// false.
bool decodeJpegWindows(const uint8_t* data, size_t size, int width, int height,
                       const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* outs,
                       std::string* why);

}  // namespace ptz::perception
