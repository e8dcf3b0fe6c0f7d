#include "perception/detect/jpeg_window.hpp"

#include <jpeglib.h>

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <vector>

#include "common/jpeg_error.hpp"
#include "common/message_check.hpp"

namespace ptz::perception {

bool decodeJpegWindow(const uint8_t* data, size_t size, int width, int height, const cv::Rect& rect,
                      cv::Mat* out, std::string* why) {
  std::vector<cv::Mat> parts;
  if (!decodeJpegWindows(data, size, width, height, {rect}, &parts, why)) return false;
  *out = parts[0];
  return true;
}

namespace {

// The header against the message's size and colour, before anything is allocated.
bool checkHeader(const uint8_t* data, size_t size, int width, int height, std::string* why) {
  JpegHeader header;
  if (!readJpegHeader(data, size, &header, why)) return false;
  if (header.width != width || header.height != height || header.channels != 3) {
    *why = "JPEG header says " + std::to_string(header.width) + "x" +
           std::to_string(header.height) + "x" + std::to_string(header.channels) + ", expected " +
           std::to_string(width) + "x" + std::to_string(height) + "x3";
    return false;
  }
  if (header.scans > kMaxJpegScans) {
    *why = "JPEG has " + std::to_string(header.scans) + " scans";
    return false;
  }
  return true;
}

}  // namespace

bool decodeJpegWindows(const uint8_t* data, size_t size, int width, int height,
                       const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* outs,
                       std::string* why) {
  if (!checkHeader(data, size, width, height, why)) return false;
  if (rects.empty()) {
    *why = "no window";
    return false;
  }
  cv::Rect all;
  for (const auto& r : rects) {
    if (r.empty() || (r & cv::Rect(0, 0, width, height)) != r) {
      *why = "window outside the image";
      return false;
    }
    all = all.empty() ? r : (all | r);
  }
  // Everything libjpeg allocates is in its pools (freed by destroy); the parts and the row are
  // declared before setjmp, so a longjmp skips no destructor of a live object.
  std::vector<cv::Mat> parts;
  for (const auto& r : rects) parts.emplace_back(r.height, r.width, CV_8UC3);
  std::vector<uint8_t> row;
  jpeg_decompress_struct info{};
  JpegError err{};
  info.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = onJpegError;
  err.mgr.emit_message = ignoreJpegMessage;
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&info);
    *why = std::string("JPEG data: ") + err.text;
    return false;
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, data, static_cast<unsigned long>(size));
  if (jpeg_read_header(&info, TRUE) != JPEG_HEADER_OK) {
    jpeg_destroy_decompress(&info);
    *why = "JPEG header incomplete";
    return false;
  }
  // cv::imdecode's settings (BGR out, the default DCT and upsampling): the same pixels.
  info.out_color_space = JCS_EXT_BGR;
  info.out_color_components = 3;
  jpeg_start_decompress(&info);
  // Columns: those of every part. libjpeg widens a crop to whole iMCUs at the left only, and its
  // fancy upsampling treats the crop's edges as the image's: one iMCU more on each side keeps the
  // parts' pixels those of a full decode.
  const int imcu = info.max_h_samp_factor * DCTSIZE;
  const int left = std::max(0, (all.x / imcu - 1) * imcu);
  const int right = std::min(width, (((all.x + all.width + imcu - 1) / imcu) + 1) * imcu);
  JDIMENSION x0 = static_cast<JDIMENSION>(left), w = static_cast<JDIMENSION>(right - left);
  if (w < info.output_width) jpeg_crop_scanline(&info, &x0, &w);
  row.resize(static_cast<size_t>(w) * 3);
  // Rows: one pass down to the last part's, the rows no part holds skipped (entropy-decoded
  // only); the rows below are never decoded. A skip starts and ends on an iMCU row and stops one
  // iMCU row before the next part: vertical upsampling reads the rows around, and skips inside a
  // row group are where libjpeg-turbo has had bugs.
  const int vimcu = info.max_v_samp_factor * DCTSIZE;
  int y = 0;
  while (y < all.br().y) {
    bool needed = false;
    int next = all.br().y;  // the first row >= y some part holds
    for (const auto& r : rects) {
      if (y >= r.y && y < r.br().y) needed = true;
      if (r.y > y) next = std::min(next, r.y);
    }
    const int skip_to = (next / vimcu - 1) * vimcu;
    if (!needed && y % vimcu == 0 && skip_to > y) {
      jpeg_skip_scanlines(&info, static_cast<JDIMENSION>(skip_to - y));
      y = skip_to;
      continue;
    }
    JSAMPROW p = row.data();
    if (jpeg_read_scanlines(&info, &p, 1) != 1) {
      jpeg_destroy_decompress(&info);
      *why = "JPEG data ends early";
      return false;
    }
    for (size_t i = 0; i < rects.size(); ++i) {
      const cv::Rect& r = rects[i];
      if (y < r.y || y >= r.br().y) continue;
      const size_t from = static_cast<size_t>(r.x - static_cast<int>(x0)) * 3;
      std::copy(row.begin() + static_cast<ptrdiff_t>(from),
                row.begin() + static_cast<ptrdiff_t>(from + static_cast<size_t>(r.width) * 3),
                parts[i].ptr(y - r.y));
    }
    ++y;
  }
  jpeg_destroy_decompress(&info);  // abort, not finish: the rows below are not read
  *outs = parts;
  return true;
}

bool decodeJpegReduced(const uint8_t* data, size_t size, int width, int height, int scale,
                       cv::Mat* out, std::string* why) {
  if (scale != 2 && scale != 4 && scale != 8) {
    *why = "scale " + std::to_string(scale) + " is none of 2, 4, 8";
    return false;
  }
  if (!checkHeader(data, size, width, height, why)) return false;
  // As in decodeJpegWindows: the image is declared before setjmp, libjpeg's memory is its pools.
  cv::Mat image((height + scale - 1) / scale, (width + scale - 1) / scale, CV_8UC3);
  jpeg_decompress_struct info{};
  JpegError err{};
  info.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = onJpegError;
  err.mgr.emit_message = ignoreJpegMessage;
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&info);
    *why = std::string("JPEG data: ") + err.text;
    return false;
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, data, static_cast<unsigned long>(size));
  if (jpeg_read_header(&info, TRUE) != JPEG_HEADER_OK) {
    jpeg_destroy_decompress(&info);
    *why = "JPEG header incomplete";
    return false;
  }
  // cv::imdecode's settings with IMREAD_REDUCED_COLOR_<scale>.
  info.out_color_space = JCS_EXT_BGR;
  info.out_color_components = 3;
  info.scale_num = 1;
  info.scale_denom = static_cast<unsigned int>(scale);
  jpeg_start_decompress(&info);
  if (static_cast<int>(info.output_width) != image.cols ||
      static_cast<int>(info.output_height) != image.rows) {
    jpeg_destroy_decompress(&info);
    *why = "JPEG reduced to " + std::to_string(info.output_width) + "x" +
           std::to_string(info.output_height) + ", expected " + std::to_string(image.cols) + "x" +
           std::to_string(image.rows);
    return false;
  }
  while (info.output_scanline < info.output_height) {
    JSAMPROW p = image.ptr(static_cast<int>(info.output_scanline));
    if (jpeg_read_scanlines(&info, &p, 1) != 1) {
      jpeg_destroy_decompress(&info);
      *why = "JPEG data ends early";
      return false;
    }
  }
  jpeg_destroy_decompress(&info);  // every row read; nothing after them is needed
  *out = image;
  return true;
}

}  // namespace ptz::perception
