// A JPEG image of a STEREO_FRAME: readJpegHeader, then decodeImage with the message's width,
// height and pixel format taken from the input. Input: pixel_format (1 byte), width and height
// (2 bytes each, big-endian), then the JPEG data. Properties: the header is read with little
// memory and gives a plausible size; decodeImage refuses what checkImage refuses and otherwise
// gives exactly the size and channels the message says. Then ptz-detect's window decode
// (decodeJpegWindow, libjpeg-turbo's crop and skip) of the whole image and of a part: it refuses
// a header that does not say the message's size in colour, and otherwise gives the part's size in
// BGR. (Its pixels equal a full decode's for valid JPEGs, test_windows.cpp; of damaged data
// cv::imdecode may give zeros where libjpeg fills in, so that is no property here.) A part at the
// bottom too; each part also through the restart index (jpeg_restart.hpp) and through the stream
// from its top: the same verdict and the same pixels, whatever the bytes. The pyramid's
// reduced decode (decodeJpegReduced) by 2, 4, 8: the same refusals, the reduced size, the same
// pixels when decoded twice; any other scale refused. A band's rows of it (decodeJpegReducedRows)
// through the restart index and from the stream's top: the same verdict, the whole's pixels.
#include <opencv2/core.hpp>

#include <algorithm>
#include <vector>

#include "common/transport/message_check.hpp"
#include "common/transport/transport.hpp"
#include "fuzz/fuzz_support.hpp"
#include "perception/jpeg/jpeg_window.hpp"

namespace {
constexpr size_t kPrefix = 5;
// Decoding costs the pixels: larger images are left to the cost measured in fuzz/README.md so
// that the fuzzer does not spend its time filling memory.
constexpr int64_t kMaxDecodedPixels = 1024 * 1024;
constexpr size_t kHeaderCostBytes = 256 * 1024;  // libjpeg's pools for reading the markers
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < kPrefix) return 0;
  ptzstereo::image_t msg{};
  msg.pixel_format = static_cast<int8_t>(data[0]);
  msg.width = data[1] << 8 | data[2];
  msg.height = data[3] << 8 | data[4];
  msg.encoding = ptzstereo::image_t::ENCODING_JPEG;
  msg.zoom = 1;
  msg.data.assign(data + kPrefix, data + size);
  msg.data_size = static_cast<int32_t>(msg.data.size());

  ptz::JpegHeader header;
  std::string why;
  ptz::fuzz::AllocationCount count;
  const bool header_ok = ptz::readJpegHeader(msg.data.data(), msg.data.size(), &header, &why);
  FUZZ_CHECK(count.bytes() <= kHeaderCostBytes,
             "reading a JPEG header allocated " + std::to_string(count.bytes()) + " bytes");
  if (header_ok) {
    FUZZ_CHECK(header.width > 0 && header.width <= 65535 && header.height > 0 &&
                   header.height <= 65535 && header.channels > 0 && header.channels <= 10,
               "implausible header " + std::to_string(header.width) + "x" +
                   std::to_string(header.height) + "x" + std::to_string(header.channels));
  } else {
    FUZZ_CHECK(!why.empty(), "a refused header without a reason");
  }

  const bool image_ok = ptz::checkImage(msg, ptz::kMaxImageSidePx, &why);
  if (image_ok) {
    FUZZ_CHECK(header_ok && header.width == msg.width && header.height == msg.height,
               "checkImage passed a JPEG whose header does not match the message");
    if (int64_t{msg.width} * msg.height > kMaxDecodedPixels) return 0;
  }
  cv::Mat image;
  const bool decoded = ptz::decodeImage(msg, &image, &why);
  if (msg.width > 0 && msg.height > 0 && int64_t{msg.width} * msg.height <= kMaxDecodedPixels) {
    const bool colour = header_ok && header.channels == 3;
    const bool same_size = header_ok && header.width == msg.width && header.height == msg.height;
    const cv::Rect whole(0, 0, msg.width, msg.height);
    const cv::Rect part(msg.width / 3, msg.height / 3, std::max(1, msg.width / 3),
                        std::max(1, msg.height / 3));
    const cv::Rect bottom(0, msg.height - std::max(1, msg.height / 4), msg.width,
                          std::max(1, msg.height / 4));
    const ptz::perception::JpegRestartIndex index(msg.data.data(), msg.data.size());
    const ptz::perception::JpegRestartIndex stream(msg.data.data(), msg.data.size(), false);
    for (const cv::Rect& r : {whole, part, bottom}) {
      cv::Mat window;
      std::string window_why;
      const bool ok = ptz::perception::decodeJpegWindow(msg.data.data(), msg.data.size(), msg.width,
                                                        msg.height, r, &window, &window_why);
      if (!(colour && same_size)) {
        FUZZ_CHECK(!ok, "decodeJpegWindow took a JPEG whose header is not the message's in colour");
        continue;
      }
      if (!ok) {
        FUZZ_CHECK(!window_why.empty(), "a refused window without a reason");
        continue;
      }
      FUZZ_CHECK(window.size() == r.size() && window.type() == CV_8UC3,
                 "a window of " + std::to_string(window.cols) + "x" + std::to_string(window.rows) +
                     " for " + std::to_string(r.width) + "x" + std::to_string(r.height));
    }
    // Restart segments against the stream from its top (with the part above it, so that two
    // bands apart are decoded when the index allows).
    for (const std::vector<cv::Rect>& rs :
         {std::vector<cv::Rect>{part}, std::vector<cv::Rect>{bottom}, {part, bottom}}) {
      std::vector<cv::Mat> fast, slow;
      std::string fast_why, slow_why;
      const bool fast_ok =
          ptz::perception::decodeJpegWindows(index, msg.width, msg.height, rs, &fast, &fast_why);
      const bool slow_ok =
          ptz::perception::decodeJpegWindows(stream, msg.width, msg.height, rs, &slow, &slow_why);
      FUZZ_CHECK(fast_ok == slow_ok, "restart segments " +
                                         std::string(fast_ok ? "took" : "refused") +
                                         " what the stream " + (slow_ok ? "took" : "refused"));
      for (size_t i = 0; fast_ok && slow_ok && i < rs.size(); ++i) {
        FUZZ_CHECK(cv::norm(fast[i], slow[i], cv::NORM_INF) == 0,
                   "restart segments gave other pixels than the stream");
      }
    }
    // The pyramid's reduced decode (libjpeg's DCT scaling): the same header rule, the reduced
    // size in BGR, the same pixels twice; other scales refused.
    for (int scale : {2, 4, 8, 0, 3}) {
      cv::Mat reduced, again;
      std::string reduced_why;
      const bool ok = ptz::perception::decodeJpegReduced(
          msg.data.data(), msg.data.size(), msg.width, msg.height, scale, &reduced, &reduced_why);
      const bool valid_scale = scale == 2 || scale == 4 || scale == 8;
      FUZZ_CHECK(ok || !reduced_why.empty(), "a refused reduced decode without a reason");
      FUZZ_CHECK(!ok || (valid_scale && colour && same_size),
                 "decodeJpegReduced took scale " + std::to_string(scale) +
                     " or a header that is not the message's in colour");
      if (!ok) {
        FUZZ_CHECK(reduced.empty(), "a refused reduced decode wrote its output");
        continue;
      }
      FUZZ_CHECK(reduced.cols == (msg.width + scale - 1) / scale &&
                     reduced.rows == (msg.height + scale - 1) / scale && reduced.type() == CV_8UC3,
                 "reduced by " + std::to_string(scale) + " to " + std::to_string(reduced.cols) +
                     "x" + std::to_string(reduced.rows));
      FUZZ_CHECK(ptz::perception::decodeJpegReduced(msg.data.data(), msg.data.size(), msg.width,
                                                    msg.height, scale, &again, &reduced_why) &&
                     cv::norm(reduced, again, cv::NORM_INF) == 0,
                 "two reduced decodes of the same bytes differ");
      // A band's rows (the middle third, from a reduced row): through the restart index and
      // through the stream from its top, the same verdict and pixels, those of the whole.
      const int row0 = msg.height / 3 / scale * scale,
                row1 = std::max(row0 + 1, 2 * msg.height / 3);
      cv::Mat by_index, by_stream;
      std::string index_why, stream_why;
      const bool index_ok = ptz::perception::decodeJpegReducedRows(
          ptz::perception::JpegRestartIndex(msg.data.data(), msg.data.size()), msg.width,
          msg.height, scale, row0, row1, &by_index, &index_why);
      const bool stream_ok = ptz::perception::decodeJpegReducedRows(
          ptz::perception::JpegRestartIndex(msg.data.data(), msg.data.size(), false), msg.width,
          msg.height, scale, row0, row1, &by_stream, &stream_why);
      FUZZ_CHECK(index_ok == stream_ok, "reduced rows: the restart path says " +
                                            std::string(index_ok ? "yes" : index_why) +
                                            ", the stream " +
                                            std::string(stream_ok ? "yes" : stream_why));
      if (index_ok && stream_ok) {
        const cv::Mat want = reduced.rowRange(row0 / scale, (row1 + scale - 1) / scale);
        FUZZ_CHECK(by_index.size() == want.size() && by_stream.size() == want.size() &&
                       cv::norm(by_index, want, cv::NORM_INF) == 0 &&
                       cv::norm(by_stream, want, cv::NORM_INF) == 0,
                   "reduced rows differ from the whole's");
      }
    }
  }
  if (!image_ok) {
    FUZZ_CHECK(!decoded, "decodeImage took an image checkImage refused");
    return 0;
  }
  if (!decoded) return 0;  // damaged entropy-coded data: refused, as it should be
  const int channels = msg.pixel_format == ptzstereo::image_t::PIXEL_GRAY8 ? 1 : 3;
  FUZZ_CHECK(
      image.cols == msg.width && image.rows == msg.height && image.type() == CV_8UC(channels),
      "decoded " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + " type " +
          std::to_string(image.type()) + " for a message of " + std::to_string(msg.width) + "x" +
          std::to_string(msg.height) + "x" + std::to_string(channels));
  return 0;
}
