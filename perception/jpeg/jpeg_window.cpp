#include "perception/jpeg/jpeg_window.hpp"

#include <jpeglib.h>

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <numeric>
#include <vector>

#include "common/transport/jpeg_error.hpp"
#include "common/transport/message_check.hpp"

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

// The parts rects[i], i in `which` (image coordinates), from a JPEG of width x height pixels
// whose top-left pixel is the image's `origin` (the whole image, or a band of MCU rows and tiles):
// (*parts)[i], already allocated. *rows: about how many of the stream's rows went through the
// entropy decoder.
bool decodeStream(const uint8_t* data, size_t size, cv::Point origin, int width, int height,
                  const std::vector<cv::Rect>& rects, const std::vector<size_t>& which,
                  std::vector<cv::Mat>* parts, std::string* why, int* rows) {
  // Everything libjpeg allocates is in its pools (freed by destroy); the vectors are declared
  // before setjmp, so a longjmp skips no destructor of a live object.
  std::vector<cv::Rect> local;  // in the stream's pixels
  for (size_t i : which) local.push_back(rects[i] - origin);
  cv::Rect all;
  for (const auto& r : local) all = all.empty() ? r : (all | r);
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
  if (jpeg_read_header(&info, TRUE) != JPEG_HEADER_OK ||
      info.image_width != static_cast<JDIMENSION>(width) ||
      info.image_height != static_cast<JDIMENSION>(height) || all.y < 0 || all.br().y > height ||
      all.x < 0 || all.br().x > width) {
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
    for (const auto& r : local) {
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
    for (size_t k = 0; k < local.size(); ++k) {
      const cv::Rect& r = local[k];
      if (y < r.y || y >= r.br().y) continue;
      const size_t from = static_cast<size_t>(r.x - static_cast<int>(x0)) * 3;
      std::copy(row.begin() + static_cast<ptrdiff_t>(from),
                row.begin() + static_cast<ptrdiff_t>(from + static_cast<size_t>(r.width) * 3),
                (*parts)[which[k]].ptr(y - r.y));
    }
    ++y;
  }
  // Context upsampling decodes an iMCU row ahead of the last row read.
  *rows = std::min(height, ((all.br().y - 1) / vimcu + 2) * vimcu);
  jpeg_destroy_decompress(&info);  // abort, not finish: the rows below are not read
  return true;
}

// The parts from restart segments: a band of MCU rows (and of tiles, when segments split the
// rows) per group of parts whose cells overlap or touch, each part's cell holding one MCU row of
// context above and below and one tile each side (fancy upsampling reads the chroma around); a
// band at the top of untiled rows is the stream itself. False when any band fails (the caller
// then decodes the stream from its top, whose verdict stands).
bool decodeBands(const JpegRestartIndex& jpeg, const std::vector<cv::Rect>& rects,
                 std::vector<cv::Mat>* parts, JpegWindowStats* stats) {
  struct Band {
    int r0, r1, c0, c1;  // MCU rows, tiles
    std::vector<size_t> which;
  };
  const int mh = jpeg.mcuHeight(), height = jpeg.height(), tw = jpeg.tileWidth();
  const int tiles = jpeg.tilesPerRow();
  std::vector<Band> bands;
  for (size_t i = 0; i < rects.size(); ++i) {
    const cv::Rect& r = rects[i];
    bands.push_back({jpeg.bandStart(std::max(0, r.y / mh - 1)),
                     std::min(jpeg.mcuRows(), (r.br().y + mh - 1) / mh + 1),
                     std::max(0, r.x / tw - 1),
                     std::min(tiles, (r.br().x + tw - 1) / tw + 1),
                     {i}});
  }
  // Apart, a second band costs its header and set-up; a gap between costs its entropy decoding:
  // only bands that touch are joined (two 1080p windows a row apart: 0.30 ms as two bands, 0.52
  // ms as one).
  for (bool joined = true; joined;) {
    joined = false;
    for (size_t a = 0; a < bands.size() && !joined; ++a) {
      for (size_t b = a + 1; b < bands.size(); ++b) {
        Band& x = bands[a];
        const Band& y = bands[b];
        if (y.r0 > x.r1 || x.r0 > y.r1 || y.c0 > x.c1 || x.c0 > y.c1) continue;
        x = {std::min(x.r0, y.r0), std::max(x.r1, y.r1), std::min(x.c0, y.c0), std::max(x.c1, y.c1),
             x.which};
        x.which.insert(x.which.end(), y.which.begin(), y.which.end());
        bands.erase(bands.begin() + static_cast<ptrdiff_t>(b));
        joined = true;
        break;
      }
    }
  }
  std::vector<uint8_t> bytes;
  std::string why;
  for (const Band& b : bands) {
    int rows = 0;
    const int y0 = b.r0 * mh, x0 = b.c0 * tw;
    const int w = std::min(b.c1 * tw, jpeg.width()) - x0;
    if (b.r0 == 0 && tiles == 1) {
      if (!decodeStream(jpeg.data(), jpeg.size(), {0, 0}, jpeg.width(), height, rects, b.which,
                        parts, &why, &rows)) {
        return false;
      }
    } else {
      if (!jpeg.tile(b.r0, b.r1, b.c0, b.c1, &bytes) ||
          !decodeStream(bytes.data(), bytes.size(), {x0, y0}, w, std::min(b.r1 * mh, height) - y0,
                        rects, b.which, parts, &why, &rows)) {
        return false;
      }
      ++stats->restart_bands;
    }
    stats->decoded_rows += rows;
    stats->decoded_width = std::max(stats->decoded_width, w);
  }
  return true;
}

}  // namespace

bool decodeJpegWindows(const uint8_t* data, size_t size, int width, int height,
                       const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* outs,
                       std::string* why) {
  // The index reads the bytes with its own bounds; the header is checked by libjpeg after it.
  return decodeJpegWindows(JpegRestartIndex(data, size), width, height, rects, outs, why);
}

bool decodeJpegWindows(const JpegRestartIndex& jpeg, int width, int height,
                       const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* outs,
                       std::string* why, JpegWindowStats* stats) {
  // A usable index has checked more than readJpegHeader (a baseline SOF of 3 components, one scan
  // and its every marker): its pass over the bytes (about 0.1 ms at 1080p) is saved.
  const bool restarts = jpeg.usable() && jpeg.width() == width && jpeg.height() == height;
  if (!restarts && !checkHeader(jpeg.data(), jpeg.size(), width, height, why)) return false;
  if (rects.empty()) {
    *why = "no window";
    return false;
  }
  for (const auto& r : rects) {
    if (r.empty() || (r & cv::Rect(0, 0, width, height)) != r) {
      *why = "window outside the image";
      return false;
    }
  }
  std::vector<cv::Mat> parts;
  for (const auto& r : rects) parts.emplace_back(r.height, r.width, CV_8UC3);
  JpegWindowStats cost;
  if (restarts && decodeBands(jpeg, rects, &parts, &cost)) {
    *outs = parts;
    if (stats != nullptr) *stats = cost;
    return true;
  }
  // The stream from its top, after the full check when it was skipped.
  if (restarts && !checkHeader(jpeg.data(), jpeg.size(), width, height, why)) return false;
  cost = {};
  std::vector<size_t> which(rects.size());
  std::iota(which.begin(), which.end(), size_t{0});
  if (!decodeStream(jpeg.data(), jpeg.size(), {0, 0}, width, height, rects, which, &parts, why,
                    &cost.decoded_rows)) {
    return false;
  }
  cost.decoded_width = width;
  *outs = parts;
  if (stats != nullptr) *stats = cost;
  return true;
}

namespace {

// The first `rows` rows of a JPEG of width x height reduced by `scale` in the decoder (header
// checked by the caller); the rest of the stream is not decoded.
bool decodeReducedStream(const uint8_t* data, size_t size, int width, int height, int scale,
                         int rows, cv::Mat* out, std::string* why) {
  // As in decodeStream: the image is declared before setjmp, libjpeg's memory is its pools.
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
  if (jpeg_read_header(&info, TRUE) != JPEG_HEADER_OK ||
      info.image_width != static_cast<JDIMENSION>(width) ||
      info.image_height != static_cast<JDIMENSION>(height)) {
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
  const JDIMENSION last = static_cast<JDIMENSION>(std::min(rows, image.rows));
  while (info.output_scanline < last) {
    JSAMPROW p = image.ptr(static_cast<int>(info.output_scanline));
    if (jpeg_read_scanlines(&info, &p, 1) != 1) {
      jpeg_destroy_decompress(&info);
      *why = "JPEG data ends early";
      return false;
    }
  }
  jpeg_destroy_decompress(&info);  // abort, not finish: nothing after these rows is needed
  *out = image.rowRange(0, static_cast<int>(last));
  return true;
}

bool validScale(int scale, std::string* why) {
  if (scale == 2 || scale == 4 || scale == 8) return true;
  *why = "scale " + std::to_string(scale) + " is none of 2, 4, 8";
  return false;
}

}  // namespace

bool decodeJpegReduced(const uint8_t* data, size_t size, int width, int height, int scale,
                       cv::Mat* out, std::string* why) {
  if (!validScale(scale, why) || !checkHeader(data, size, width, height, why)) return false;
  return decodeReducedStream(data, size, width, height, scale, (height + scale - 1) / scale, out,
                             why);
}

bool decodeJpegReducedRows(const JpegRestartIndex& jpeg, int width, int height, int scale, int row0,
                           int row1, cv::Mat* out, std::string* why, JpegWindowStats* stats) {
  if (!validScale(scale, why)) return false;
  if (row0 < 0 || row0 >= row1 || row1 > height || row0 % scale != 0) {
    *why = "rows " + std::to_string(row0) + ".." + std::to_string(row1) + " not in the image";
    return false;
  }
  const int out0 = row0 / scale, out1 = (row1 + scale - 1) / scale;
  const int mh = jpeg.mcuHeight();
  JpegWindowStats cost;
  cv::Mat image;
  // A band of the MCU rows with one of context above and below (as decodeBands): the pixels of
  // the whole decode's rows (the tests compare them).
  if (jpeg.usable() && jpeg.width() == width && jpeg.height() == height && mh % scale == 0) {
    const int r0 = jpeg.bandStart(std::max(0, row0 / mh - 1));
    const int r1 = std::min(jpeg.mcuRows(), (row1 + mh - 1) / mh + 1);
    const int top = r0 * mh / scale;  // the band's first row in the reduced image
    std::vector<uint8_t> bytes;
    std::string ignored;  // a failing band: the stream from its top decides
    const bool ok = r0 == 0 ? decodeReducedStream(jpeg.data(), jpeg.size(), width, height, scale,
                                                  out1, &image, &ignored)
                            : jpeg.band(r0, r1, &bytes) &&
                                  decodeReducedStream(bytes.data(), bytes.size(), width,
                                                      std::min(r1 * mh, height) - r0 * mh, scale,
                                                      out1 - top, &image, &ignored);
    if (ok && image.rows == out1 - top) {
      cost.restart_bands = r0 == 0 ? 0 : 1;
      cost.decoded_rows = std::min(r1 * mh, height) - r0 * mh;
      *out = image.rowRange(out0 - top, out1 - top);
      if (stats != nullptr) *stats = cost;
      return true;
    }
  }
  if (!checkHeader(jpeg.data(), jpeg.size(), width, height, why) ||
      !decodeReducedStream(jpeg.data(), jpeg.size(), width, height, scale, out1, &image, why)) {
    return false;
  }
  cost.decoded_rows = std::min(height, out1 * scale);
  *out = image.rowRange(out0, out1);
  if (stats != nullptr) *stats = cost;
  return true;
}

}  // namespace ptz::perception
