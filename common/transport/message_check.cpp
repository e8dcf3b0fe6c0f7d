#include "common/transport/message_check.hpp"

#include <jpeglib.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <exception>

#include "common/transport/jpeg_error.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/point_cloud_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/target_select_t.hpp"

namespace ptz {
namespace {

// Reads an LCM encoding (big-endian, counts before their arrays) without allocating.
class Cursor {
 public:
  Cursor(const void* data, size_t size) : p_(static_cast<const uint8_t*>(data)), left_(size) {}

  bool skip(size_t n, const char* field) {
    if (n > left_) return fail(std::string(field) + " runs past the end of the message");
    p_ += n;
    left_ -= n;
    return true;
  }
  bool i32(int32_t* v, const char* field) {
    if (left_ < 4) return fail(std::string(field) + " runs past the end of the message");
    *v = static_cast<int32_t>((uint32_t{p_[0]} << 24) | (uint32_t{p_[1]} << 16) |
                              (uint32_t{p_[2]} << 8) | uint32_t{p_[3]});
    return skip(4, field);
  }
  bool i64(int64_t* v, const char* field) {
    int32_t hi = 0, lo = 0;
    if (!i32(&hi, field) || !i32(&lo, field)) return false;
    *v = static_cast<int64_t>((static_cast<uint64_t>(static_cast<uint32_t>(hi)) << 32) |
                              static_cast<uint32_t>(lo));
    return true;
  }
  // A string: its length with the terminating NUL, then the bytes.
  bool str(const char* field) {
    int32_t len = 0;
    if (!i32(&len, field)) return false;
    if (len < 1) return fail(std::string(field) + " has length " + std::to_string(len));
    if (static_cast<size_t>(len) > left_) return skip(static_cast<size_t>(len), field);
    // One C string: its NUL last and nowhere before (lcm-gen would keep or drop bytes silently).
    if (p_[len - 1] != 0 || std::memchr(p_, 0, static_cast<size_t>(len - 1)) != nullptr) {
      return fail(std::string(field) + " is not one NUL-terminated string");
    }
    return skip(static_cast<size_t>(len), field);
  }
  // A count that sizes an array: not negative, and each element takes at least min_bytes.
  bool count(int32_t* n, size_t min_bytes, const char* field) {
    if (!i32(n, field)) return false;
    if (*n < 0) return fail(std::string(field) + " is negative (" + std::to_string(*n) + ")");
    if (static_cast<size_t>(*n) > left_ / min_bytes) {
      return fail(std::string(field) + " = " + std::to_string(*n) + " but only " +
                  std::to_string(left_) + " bytes follow");
    }
    return true;
  }
  bool hash(int64_t expected) {
    int64_t h = 0;
    if (!i64(&h, "fingerprint")) return false;
    if (h != expected) return fail("fingerprint is not this message type's");
    return true;
  }
  bool fail(const std::string& why) {
    if (why_.empty()) why_ = why;
    return false;
  }
  size_t left() const { return left_; }
  const std::string& why() const { return why_; }

 private:
  const uint8_t* p_;
  size_t left_;
  std::string why_;
};

template <class Fixed>
size_t fixedSize() {
  return static_cast<size_t>(Fixed{}._getEncodedSizeNoHash());
}

// Smallest encodings of the elements of variable arrays (a string takes at least 5 bytes).
constexpr size_t kMinString = 5;
// An object_track_t after its id and class_name: state; position, velocity and their
// covariances, acceleration, radius, age_s, since_update_s (30 doubles); object_index,
// untrusted_updates; has_orientation; orientation and its covariance (13 doubles).
constexpr size_t kTrackAfterName = 1 + 30 * 8 + 2 * 4 + 1 + 13 * 8;
// An object_3d_t after its class_name: position, covariance, radius (13 doubles); left_index,
// right_index; has_orientation; orientation and its covariance (13 doubles).
constexpr size_t kObjectAfterName = 13 * 8 + 2 * 4 + 1 + 13 * 8;
// A sim_object_truth_t after its three strings: position, velocity, radius, orientation,
// visible fractions.
constexpr size_t kTruthAfterStrings = 13 * 8;

bool walkImage(Cursor& c, const char* side) {
  int32_t n = 0;
  // width, height, row_stride; pixel_format, encoding; pan, tilt, zoom.
  if (!c.skip(3 * 4 + 2 + 3 * 8, side)) return false;
  return c.count(&n, 1, "data_size") && c.skip(static_cast<size_t>(n), "data");
}

bool walkDetections(Cursor& c, const char* field) {
  int32_t n = 0;
  if (!c.count(&n, kMinString + 3 * 8 + 4 * 4 + 8 + 4, field)) return false;
  for (int32_t i = 0; i < n; ++i) {
    if (!c.str("class_name") || !c.skip(3 * 8 + 4 * 4 + 8 + 4, field)) return false;
  }
  return true;
}

bool walk(Cursor& c, const ptzstereo::stereo_frame_t*) {
  return c.skip(3 * 8, "header") && walkImage(c, "left") && walkImage(c, "right");
}
bool walk(Cursor& c, const ptzstereo::control_state_t*) {
  // utime, publish_utime, frame_seq, state, target_id, since_target_s, the two waypoint counts.
  return c.skip(3 * 8 + 1 + 2 * 8 + 2 * 4, "header") && c.str("reason");
}
bool walk(Cursor& c, const ptzstereo::object_detections_t*) {
  return c.skip(3 * 8, "header") && walkDetections(c, "num_left") && walkDetections(c, "num_right");
}
bool walk(Cursor& c, const ptzstereo::object_pose_t*) {
  int32_t n = 0;
  if (!c.skip(3 * 8 + 2 * fixedSize<ptzstereo::ptz_head_setpoint_t>() + 4, "header")) return false;
  if (!c.count(&n, kMinString + kObjectAfterName, "num_objects")) return false;
  for (int32_t i = 0; i < n; ++i) {
    if (!c.str("class_name") || !c.skip(kObjectAfterName, "objects")) return false;
  }
  return true;
}
bool walk(Cursor& c, const ptzstereo::object_tracks_t*) {
  int32_t n = 0;
  if (!c.skip(3 * 8 + 2 * fixedSize<ptzstereo::ptz_head_setpoint_t>() + 8, "header") ||
      !c.str("target_reason") || !c.count(&n, 8 + kMinString + kTrackAfterName, "num_tracks")) {
    return false;
  }
  for (int32_t i = 0; i < n; ++i) {
    if (!c.skip(8, "tracks.id") || !c.str("tracks.class_name") ||
        !c.skip(kTrackAfterName, "tracks")) {
      return false;
    }
  }
  return true;
}
bool walk(Cursor& c, const ptzstereo::point_cloud_t*) {
  int32_t n = 0;
  if (!c.skip(3 * 8, "header") || !c.str("frame_id") || !c.skip(2 * 4 + 2, "width")) return false;
  if (!c.count(&n, kMinString + 4 + 1 + 4, "num_fields")) return false;
  for (int32_t i = 0; i < n; ++i) {
    if (!c.str("fields.name") || !c.skip(4 + 1 + 4, "fields")) return false;
  }
  return c.skip(2 * 4, "point_step") && c.count(&n, 1, "data_size") &&
         c.skip(static_cast<size_t>(n), "data");
}
bool walk(Cursor& c, const ptzstereo::process_status_t*) {
  int32_t n = 0;
  if (!c.skip(8, "utime") || !c.str("process") || !c.str("hostname") || !c.skip(4 + 8 + 1, "pid") ||
      !c.str("message") || !c.count(&n, kMinString + 1 + 8 + 2 * 8 + 2 * 8, "num_channels")) {
    return false;
  }
  for (int32_t i = 0; i < n; ++i) {
    if (!c.str("channels.channel") || !c.skip(1 + 8 + 2 * 8 + 2 * 8, "channels")) return false;
  }
  if (!c.count(&n, kMinString + 8, "num_counters")) return false;
  for (int32_t i = 0; i < n; ++i) {
    if (!c.str("counters.name") || !c.skip(8, "counters")) return false;
  }
  return true;
}
bool walk(Cursor& c, const ptzstereo::ptz_setpoint_t*) {
  return c.skip(fixedSize<ptzstereo::ptz_setpoint_t>(), "setpoint");
}
bool walk(Cursor& c, const ptzstereo::ptz_state_t*) {
  return c.skip(fixedSize<ptzstereo::ptz_state_t>(), "state");
}
bool walk(Cursor& c, const ptzstereo::sim_truth_t*) {
  int32_t n = 0;
  const size_t heads =
      2 * fixedSize<ptzstereo::ptz_head_state_t>() + 2 * fixedSize<ptzstereo::camera_model_t>();
  if (!c.skip(3 * 8 + heads, "header") ||
      !c.count(&n, 3 * kMinString + kTruthAfterStrings, "num_objects")) {
    return false;
  }
  for (int32_t i = 0; i < n; ++i) {
    if (!c.str("name") || !c.str("class_name") || !c.str("shape") ||
        !c.skip(kTruthAfterStrings, "objects")) {
      return false;
    }
  }
  return true;
}
bool walk(Cursor& c, const ptzstereo::target_select_t*) {
  // utime, publish_utime, mode; class_name; track_id, camera, x_px, y_px, frame_seq.
  return c.skip(2 * 8 + 1, "header") && c.str("class_name") && c.skip(8 + 1 + 3 * 8, "track_id");
}

}  // namespace

template <class Msg>
bool checkEncoding(const void* data, size_t size, std::string* why) {
  Cursor c(data, size);
  bool ok = c.hash(Msg::getHash()) && walk(c, static_cast<const Msg*>(nullptr));
  if (ok && c.left() != 0) ok = c.fail(std::to_string(c.left()) + " bytes after the message");
  if (!ok && why) *why = std::string(Msg::getTypeName()) + ": " + c.why();
  return ok;
}

template <class Msg>
bool decodeChecked(const void* data, size_t size, Msg* msg, std::string* why) {
  if (size > static_cast<size_t>(INT32_MAX)) {
    if (why) *why = "message larger than 2 GB";
    return false;
  }
  if (!checkEncoding<Msg>(data, size, why)) return false;
  try {
    if (msg->decode(data, 0, static_cast<int>(size)) >= 0) return true;
  } catch (const std::exception& e) {
    if (why) *why = std::string(Msg::getTypeName()) + ": " + e.what();
    return false;
  }
  if (why) *why = std::string(Msg::getTypeName()) + ": does not decode";
  return false;
}

#define PTZ_CHECKED_MESSAGE(T)                                                  \
  template bool checkEncoding<ptzstereo::T>(const void*, size_t, std::string*); \
  template bool decodeChecked<ptzstereo::T>(const void*, size_t, ptzstereo::T*, std::string*);
PTZ_CHECKED_MESSAGE(stereo_frame_t)
PTZ_CHECKED_MESSAGE(control_state_t)
PTZ_CHECKED_MESSAGE(object_detections_t)
PTZ_CHECKED_MESSAGE(object_pose_t)
PTZ_CHECKED_MESSAGE(object_tracks_t)
PTZ_CHECKED_MESSAGE(point_cloud_t)
PTZ_CHECKED_MESSAGE(process_status_t)
PTZ_CHECKED_MESSAGE(ptz_setpoint_t)
PTZ_CHECKED_MESSAGE(ptz_state_t)
PTZ_CHECKED_MESSAGE(sim_truth_t)
PTZ_CHECKED_MESSAGE(target_select_t)
#undef PTZ_CHECKED_MESSAGE

namespace {
// Entropy-coded data stuffs every 0xFF with 0x00: FF DA is a start-of-scan marker wherever it is.
// memchr to each 0xFF: a 1080p frame in microseconds, not a tenth of a millisecond byte by byte.
// Not inlined: readJpegHeader's setjmp frame must not hold its loop's variables.
__attribute__((noinline)) int countStartOfScan(const uint8_t* data, size_t size) {
  int scans = 0;
  const uint8_t* end = data + size;
  for (const uint8_t* p = data; p + 1 < end; ++p) {
    p = static_cast<const uint8_t*>(std::memchr(p, 0xFF, static_cast<size_t>(end - 1 - p)));
    if (!p) break;
    if (p[1] == 0xDA) ++scans;
  }
  return scans;
}
}  // namespace

bool readJpegHeader(const uint8_t* data, size_t size, JpegHeader* header, std::string* why) {
  // The start-of-image marker and a marker after it: OpenCV picks its decoder from the bytes, and
  // garbage after FF D8 that libjpeg skips could make it take another format (DICOM aborts).
  if (size < 4 || data[0] != 0xFF || data[1] != 0xD8 || data[2] != 0xFF) {
    *why = "not a JPEG (no start-of-image marker followed by a marker)";
    return false;
  }
  jpeg_decompress_struct info{};
  JpegError err{};
  info.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = onJpegError;
  err.mgr.emit_message = ignoreJpegMessage;
  // Nothing below allocates what a setjmp would skip: libjpeg frees its pools in destroy.
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&info);
    *why = std::string("JPEG header: ") + err.text;
    return false;
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, data, static_cast<unsigned long>(size));
  const int status = jpeg_read_header(&info, TRUE);
  header->width = static_cast<int>(info.image_width);
  header->height = static_cast<int>(info.image_height);
  header->channels = info.num_components;
  jpeg_destroy_decompress(&info);
  if (status != JPEG_HEADER_OK) {
    *why = "JPEG header incomplete";
    return false;
  }
  header->scans = countStartOfScan(data, size);
  return true;
}

bool checkImage(const ptzstereo::image_t& msg, int max_side_px, std::string* why) {
  int channels = 0;
  switch (msg.pixel_format) {
    case ptzstereo::image_t::PIXEL_GRAY8:
      channels = 1;
      break;
    case ptzstereo::image_t::PIXEL_BGR8:
    case ptzstereo::image_t::PIXEL_RGB8:
      channels = 3;
      break;
    default:
      *why = "unknown pixel_format " + std::to_string(msg.pixel_format);
      return false;
  }
  if (msg.width <= 0 || msg.height <= 0 || msg.width > max_side_px || msg.height > max_side_px) {
    *why = "size " + std::to_string(msg.width) + "x" + std::to_string(msg.height) + " outside 1.." +
           std::to_string(max_side_px);
    return false;
  }
  if (msg.data_size < 0 || static_cast<size_t>(msg.data_size) != msg.data.size()) {
    *why = "data_size " + std::to_string(msg.data_size) + " but " +
           std::to_string(msg.data.size()) + " bytes of data";
    return false;
  }
  if (!std::isfinite(msg.pan_rad) || !std::isfinite(msg.tilt_rad) || !std::isfinite(msg.zoom)) {
    *why = "non-finite pan/tilt/zoom";
    return false;
  }
  if (msg.encoding == ptzstereo::image_t::ENCODING_RAW) {
    if (msg.row_stride < msg.width * channels ||
        static_cast<int64_t>(msg.row_stride) * msg.height > msg.data_size) {
      *why = "raw data truncated or row_stride " + std::to_string(msg.row_stride) + " too small";
      return false;
    }
    return true;
  }
  if (msg.encoding != ptzstereo::image_t::ENCODING_JPEG) {
    *why = "unknown encoding " + std::to_string(msg.encoding);
    return false;
  }
  JpegHeader jpeg;
  if (!readJpegHeader(msg.data.data(), msg.data.size(), &jpeg, why)) return false;
  if (jpeg.width != msg.width || jpeg.height != msg.height) {
    *why = "JPEG header says " + std::to_string(jpeg.width) + "x" + std::to_string(jpeg.height) +
           ", the message " + std::to_string(msg.width) + "x" + std::to_string(msg.height);
    return false;
  }
  // Every 8x8 luma block of a complete JPEG takes at least one bit (its DC code): fewer bytes
  // are a truncated or forged image, which libjpeg would decode anyway, filling in the rest.
  const int64_t min_bytes = (static_cast<int64_t>(msg.width + 7) / 8) * ((msg.height + 7) / 8) / 8;
  if (static_cast<int64_t>(msg.data.size()) < min_bytes) {
    *why = "JPEG of " + std::to_string(msg.data.size()) + " bytes cannot hold " +
           std::to_string(msg.width) + "x" + std::to_string(msg.height) + " (at least " +
           std::to_string(min_bytes) + ")";
    return false;
  }
  if (jpeg.scans > kMaxJpegScans) {
    *why = "JPEG has " + std::to_string(jpeg.scans) + " scans, more than " +
           std::to_string(kMaxJpegScans);
    return false;
  }
  if (jpeg.channels != channels) {
    *why = "JPEG has " + std::to_string(jpeg.channels) + " channels, pixel_format " +
           std::to_string(msg.pixel_format) + " needs " + std::to_string(channels);
    return false;
  }
  return true;
}

bool checkStereoFrame(const ptzstereo::stereo_frame_t& frame, int max_side_px, std::string* why) {
  if (!checkImage(frame.left, max_side_px, why)) {
    *why = "left image: " + *why;
    return false;
  }
  if (!checkImage(frame.right, max_side_px, why)) {
    *why = "right image: " + *why;
    return false;
  }
  return true;
}

bool checkFrameMatchesRig(const ptzstereo::stereo_frame_t& frame, int width, int height,
                          std::string* why) {
  for (const ptzstereo::image_t* im : {&frame.left, &frame.right}) {
    if (im->width == width && im->height == height &&
        im->pixel_format != ptzstereo::image_t::PIXEL_GRAY8) {
      continue;
    }
    *why = std::string("the ") + (im == &frame.left ? "left" : "right") + " image is " +
           std::to_string(im->width) + "x" + std::to_string(im->height) +
           (im->pixel_format == ptzstereo::image_t::PIXEL_GRAY8 ? " gray" : " colour") +
           ", the rig is for " + std::to_string(width) + "x" + std::to_string(height) + " colour";
    return false;
  }
  return true;
}

bool checkPreviewMatchesRig(const ptzstereo::stereo_frame_t& frame, int width, int height,
                            std::string* why) {
  const int64_t rig_w = width, rig_h = height;
  for (const ptzstereo::image_t* im : {&frame.left, &frame.right}) {
    const int64_t w = im->width, h = im->height;
    if (w >= 16 && w <= rig_w && h >= 1 && h <= rig_h && std::abs(w * rig_h - h * rig_w) <= rig_w &&
        im->pixel_format != ptzstereo::image_t::PIXEL_GRAY8) {
      continue;
    }
    *why = std::string("the ") + (im == &frame.left ? "left" : "right") + " preview is " +
           std::to_string(w) + "x" + std::to_string(h) +
           (im->pixel_format == ptzstereo::image_t::PIXEL_GRAY8 ? " gray" : " colour") +
           ", not a colour image of the rig's " + std::to_string(width) + "x" +
           std::to_string(height) + " shape";
    return false;
  }
  return true;
}

bool decodeImage(const ptzstereo::image_t& msg, cv::Mat* image, std::string* error) {
  if (!checkImage(msg, kMaxImageSidePx, error)) return false;
  const int channels = msg.pixel_format == ptzstereo::image_t::PIXEL_GRAY8 ? 1 : 3;
  if (msg.encoding == ptzstereo::image_t::ENCODING_RAW) {
    cv::Mat view(msg.height, msg.width, CV_8UC(channels), const_cast<uint8_t*>(msg.data.data()),
                 static_cast<size_t>(msg.row_stride));
    view.copyTo(*image);
  } else {
    // The header has been checked against width, height and channels: the decoded size is known.
    // EXIF orientation is ignored: a camera's frame is as its header says.
    *image = cv::imdecode(msg.data, (channels == 3 ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE) |
                                        cv::IMREAD_IGNORE_ORIENTATION);
    if (image->empty() || image->cols != msg.width || image->rows != msg.height) {
      *error = "JPEG data does not decode";
      return false;
    }
  }
  if (msg.pixel_format == ptzstereo::image_t::PIXEL_RGB8) {
    cv::cvtColor(*image, *image, cv::COLOR_RGB2BGR);
  }
  return true;
}

}  // namespace ptz
