// Decoding only a part of a JPEG (libjpeg-turbo's jpeg_crop_scanline and jpeg_skip_scanlines):
// with a window around a tracked object ptz-detect needs a few rows and columns, not the frame.
// Or all of it at a fraction of the size (a pyramid full scan's level), scaled in the IDCT.
// The header is checked against the size the message claims before anything is allocated.
// A JPEG with restart markers at MCU rows (encodeImage writes them) is decoded from the segments
// of the windows' rows alone (jpeg_restart.hpp): the same pixels, without the rows above.
#pragma once

#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "perception/jpeg/jpeg_restart.hpp"

namespace ptz::perception {

// The pixels of `rect` (full-image coordinates, inside width x height) of a colour JPEG that must
// be width x height with 3 components, as 8-bit BGR (as cv::imdecode gives them: the same pixels
// as the same part of a full decode). False and why for anything else; *out is then untouched.
bool decodeJpegWindow(const uint8_t* data, size_t size, int width, int height, const cv::Rect& rect,
                      cv::Mat* out, std::string* why);
// Several parts in one pass: the rows of each (those between skipped, entropy-decoded only, or
// with restart markers not decoded at all) and the columns of all; (*outs)[i] the pixels of
// rects[i]. The same checks; *outs untouched when false.
bool decodeJpegWindows(const uint8_t* data, size_t size, int width, int height,
                       const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* outs,
                       std::string* why);
// What a window decode cost, for tests and counters.
struct JpegWindowStats {
  int restart_bands = 0;  // bands decoded from restart segments (0: the stream from its top)
  int decoded_rows = 0;   // image rows whose MCUs went through the entropy decoder (about)
  int decoded_width = 0;  // of those rows' columns, the widest band's (px)
};
// decodeJpegWindows with the image's restart index built once (`jpeg`: its bytes, JpegRestartIndex
// of them) for the several decodes of one image in a frame. An unusable index takes the path
// above: the same pixels either way.
bool decodeJpegWindows(const JpegRestartIndex& jpeg, int width, int height,
                       const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* outs,
                       std::string* why, JpegWindowStats* stats = nullptr);
// The whole image reduced by `scale` (2, 4 or 8) in the decoder (libjpeg's scale_num 1 /
// scale_denom: a smaller IDCT per block, so no full-size pixel is made): (width + scale - 1) /
// scale x (height + scale - 1) / scale BGR pixels, close to the area average of a full decode.
// The same checks; *out untouched when false.
bool decodeJpegReduced(const uint8_t* data, size_t size, int width, int height, int scale,
                       cv::Mat* out, std::string* why);
// Rows [row0, row1) of the whole image (row0 a multiple of scale) reduced by `scale`: the reduced
// image's rows row0 / scale up to (row1 + scale - 1) / scale, the same pixels as decodeJpegReduced
// gives there, decoded (with restart markers) from the segments of those rows alone. A banded full
// scan's band (windows.hpp). The same checks; *out untouched when false.
bool decodeJpegReducedRows(const JpegRestartIndex& jpeg, int width, int height, int scale, int row0,
                           int row1, cv::Mat* out, std::string* why,
                           JpegWindowStats* stats = nullptr);

}  // namespace ptz::perception
