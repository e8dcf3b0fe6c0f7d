// One LCM message type's checked decode (common/transport/message_check.hpp), built once per type
// with PTZ_FUZZ_MESSAGE set to its name (fuzz/CMakeLists.txt). Properties:
// - checkEncoding allocates nothing worth counting, and decodeChecked agrees with it;
// - rejected: nothing allocated beyond the input's size;
// - accepted: lcm-gen's own decode takes exactly these bytes, the decoded message costs at most
//   a small multiple of its size, and re-encoding it gives the same bytes;
// - stereo_frame_t: checkStereoFrame, then decodeImage of both images, which must give the size
//   and channels the message says (or refuse).
#include <opencv2/core.hpp>

#include <cstring>
#include <type_traits>
#include <vector>

#include "common/transport/message_check.hpp"
#include "common/transport/transport.hpp"
#include "fuzz/fuzz_support.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/point_cloud_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"

using Msg = ptzstereo::PTZ_FUZZ_MESSAGE;

namespace {

using ptz::fuzz::AllocationCount;

// A checked message may cost this many times its encoded size in memory (lcm-gen's structs are
// at most ~3.1x their smallest encoding: an empty-named counter_t is 13 bytes, 40 in memory).
constexpr size_t kDecodeCostFactor = 4;
constexpr size_t kSlackBytes = 4096;  // error texts, small vectors

[[maybe_unused]] void checkDecode(const ptzstereo::image_t& image, bool frame_ok,
                                  const char* side) {
  const std::string name = std::string(side) + " image";
  std::string why;
  const bool image_ok = ptz::checkImage(image, ptz::kMaxImageSidePx, &why);
  if (frame_ok) FUZZ_CHECK(image_ok, name + " refused in a frame that passed: " + why);
  // A JPEG passes the checks by its header alone; a large one costs its pixels (the frame target
  // is about the message, fuzz_jpeg about the decoder; fuzz/README.md has the cost measured).
  if (image_ok && image.encoding == ptzstereo::image_t::ENCODING_JPEG &&
      int64_t{image.width} * image.height > 1024 * 1024) {
    return;
  }
  cv::Mat decoded;
  AllocationCount count;
  const bool decoded_ok = ptz::decodeImage(image, &decoded, &why);
  const size_t cost = count.bytes();
  if (!image_ok) {
    FUZZ_CHECK(!decoded_ok, name + " decoded although checkImage refused it");
    return;
  }
  if (image.encoding == ptzstereo::image_t::ENCODING_RAW) {
    FUZZ_CHECK(decoded_ok, name + ": raw image that passed the checks does not decode: " + why);
    // The copy, and for RGB the conversion beside it.
    FUZZ_CHECK(cost <= 2 * image.data.size() + 3 * kSlackBytes,
               name + ": decoding a raw image of " + std::to_string(image.data.size()) +
                   " bytes allocated " + std::to_string(cost));
  }
  if (!decoded_ok) return;
  const int channels = image.pixel_format == ptzstereo::image_t::PIXEL_GRAY8 ? 1 : 3;
  FUZZ_CHECK(decoded.cols == image.width && decoded.rows == image.height &&
                 decoded.type() == CV_8UC(channels),
             name + ": decoded " + std::to_string(decoded.cols) + "x" +
                 std::to_string(decoded.rows) + " type " + std::to_string(decoded.type()) +
                 ", the message says " + std::to_string(image.width) + "x" +
                 std::to_string(image.height) + " with " + std::to_string(channels) + " channels");
}

// Only a frame has images (a template, so that the branch is discarded for other types).
template <class M>
void checkImages(const M& msg) {
  if constexpr (std::is_same_v<M, ptzstereo::stereo_frame_t>) {
    std::string why;
    const bool frame_ok = ptz::checkStereoFrame(msg, ptz::kMaxImageSidePx, &why);
    checkDecode(msg.left, frame_ok, "left");
    checkDecode(msg.right, frame_ok, "right");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string why;
  AllocationCount count;
  const bool ok = ptz::checkEncoding<Msg>(data, size, &why);
  FUZZ_CHECK(count.bytes() <= kSlackBytes,
             "checkEncoding allocated " + std::to_string(count.bytes()) + " bytes");

  Msg msg;
  std::string decode_why;
  count.start();
  const bool decoded = ptz::decodeChecked(data, size, &msg, &decode_why);
  const size_t cost = count.bytes();
  FUZZ_CHECK(decoded == ok, "checkEncoding says " + std::to_string(ok) + " (" + why +
                                "), decodeChecked " + std::to_string(decoded) + " (" + decode_why +
                                ")");
  if (!ok) {
    FUZZ_CHECK(cost <= size + kSlackBytes, "a refused message of " + std::to_string(size) +
                                               " bytes allocated " + std::to_string(cost));
    return 0;
  }
  FUZZ_CHECK(cost <= kDecodeCostFactor * size + kSlackBytes,
             "a message of " + std::to_string(size) + " bytes took " + std::to_string(cost) +
                 " bytes to decode");

  Msg plain;
  FUZZ_CHECK(plain.decode(data, 0, static_cast<int>(size)) == static_cast<int>(size),
             "lcm-gen's decode does not take the accepted bytes");
  const int encoded_size = msg.getEncodedSize();
  FUZZ_CHECK(
      encoded_size == static_cast<int>(size),
      "re-encoded size " + std::to_string(encoded_size) + ", the input " + std::to_string(size));
  std::vector<uint8_t> again(size);
  FUZZ_CHECK(msg.encode(again.data(), 0, encoded_size) == encoded_size, "re-encoding fails");
  size_t first_difference = 0;
  while (first_difference < size && again[first_difference] == data[first_difference]) {
    ++first_difference;
  }
  FUZZ_CHECK(first_difference == size,
             "re-encoded bytes differ from byte " + std::to_string(first_difference));

  checkImages(msg);
  return 0;
}
