// A recorded JPEG file as ptz-camera reads it (ptz_driver/cameras/sources/jpeg_file.hpp): its
// bytes are published undecoded when checkPassThroughJpeg takes them. Input: the published width
// and height (2 bytes each, big-endian; 0 x 0 takes any size), then the file's bytes.
// Properties: a refusal says why; what is taken has the published size (or any within
// kMaxImageSidePx), and the consumers' own check (checkImage) takes it as the BGR8 JPEG image
// ptz-camera publishes, so nothing passed through is dropped by every consumer; decodeImage then
// gives that size in BGR or refuses with a reason (damaged entropy data may not decode, which
// ptz-camera counts as previews_undecodable).
#include <opencv2/core.hpp>

#include <string>

#include "common/transport/message_check.hpp"
#include "common/transport/transport.hpp"
#include "fuzz/fuzz_support.hpp"
#include "ptz_driver/cameras/sources/jpeg_file.hpp"

namespace {
constexpr size_t kPrefix = 4;
constexpr int64_t kMaxDecodedPixels = 1024 * 1024;  // as fuzz_jpeg: larger ones are not decoded
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < kPrefix) return 0;
  const int width = data[0] << 8 | data[1];
  const int height = data[2] << 8 | data[3];
  const uint8_t* file = data + kPrefix;
  const size_t file_size = size - kPrefix;

  int out_width = -1, out_height = -1;
  std::string why;
  const bool passed = ptz::driver::checkPassThroughJpeg(file, file_size, width, height, &out_width,
                                                        &out_height, &why);
  if (!passed) {
    FUZZ_CHECK(!why.empty(), "a refused file without a reason");
    return 0;
  }
  FUZZ_CHECK(out_width >= 1 && out_height >= 1 && out_width <= ptz::kMaxImageSidePx &&
                 out_height <= ptz::kMaxImageSidePx,
             "passed through at " + std::to_string(out_width) + "x" + std::to_string(out_height));
  FUZZ_CHECK(width == 0 || (out_width == width && out_height == height),
             "published at " + std::to_string(width) + "x" + std::to_string(height) +
                 ", passed through at " + std::to_string(out_width) + "x" +
                 std::to_string(out_height));

  ptzstereo::image_t msg{};
  msg.width = out_width;
  msg.height = out_height;
  msg.pixel_format = ptzstereo::image_t::PIXEL_BGR8;
  msg.encoding = ptzstereo::image_t::ENCODING_JPEG;
  msg.zoom = 1;
  msg.data.assign(file, file + file_size);
  msg.data_size = static_cast<int32_t>(msg.data.size());
  FUZZ_CHECK(ptz::checkImage(msg, ptz::kMaxImageSidePx, &why),
             "passed through what consumers refuse: " + why);
  if (int64_t{out_width} * out_height > kMaxDecodedPixels) return 0;
  cv::Mat image;
  why.clear();
  if (ptz::decodeImage(msg, &image, &why)) {
    FUZZ_CHECK(image.cols == out_width && image.rows == out_height && image.type() == CV_8UC3,
               "decoded to " + std::to_string(image.cols) + "x" + std::to_string(image.rows));
  } else {
    FUZZ_CHECK(!why.empty(), "a passed-through image that does not decode, without a reason");
  }
  return 0;
}
