// A JPEG image of a STEREO_FRAME: readJpegHeader, then decodeImage with the message's width,
// height and pixel format taken from the input. Input: pixel_format (1 byte), width and height
// (2 bytes each, big-endian), then the JPEG data. Properties: the header is read with little
// memory and gives a plausible size; decodeImage refuses what checkImage refuses and otherwise
// gives exactly the size and channels the message says.
#include <opencv2/core.hpp>

#include "common/message_check.hpp"
#include "common/transport.hpp"
#include "fuzz/fuzz_support.hpp"

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
