// Checks the bytes of an LCM message before anything is allocated for them: lcm-gen's decoders
// resize arrays to the sender's counts before they look at the buffer, so a 60-byte message can
// ask for gigabytes. checkEncoding walks the encoding (fingerprint, every count and string length
// against the bytes left) without allocating; decodeChecked decodes only what passed, so a message
// costs at most its own size. Then the contents: images (both of a frame alike, a JPEG's own header
// against the message's width, height and format), finite numbers where a consumer needs them;
// and an image's pixels once it passed (decodeImage). No LCM: the message types alone.
#pragma once

#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <string>

#include "ptzstereo/image_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz {

// True when data[0, size) is exactly one well-formed Msg; else false and why.
template <class Msg>
bool checkEncoding(const void* data, size_t size, std::string* why);

// checkEncoding, then Msg::decode; never throws. False and why for anything malformed.
template <class Msg>
bool decodeChecked(const void* data, size_t size, Msg* msg, std::string* why);

// The largest image side accepted from outside, pixels (above a 4K UHD sensor's 3840): a frame
// then decodes to at most 2 x 48 MB. Consumers with a rig also hold frames to the rig's size.
constexpr int kMaxImageSidePx = 4096;

// Width, height, channels and layout of a JPEG, read from its header alone.
struct JpegHeader {
  int width = 0;
  int height = 0;
  int channels = 0;
  // Start-of-scan markers in the data: a progressive JPEG of a few hundred bytes can hold
  // thousands of scans, each a pass over the whole image when decoded.
  int scans = 0;
};
// A camera's JPEG has 1 (baseline) to about 10 (progressive) scans.
constexpr int kMaxJpegScans = 32;
// Parses the header with libjpeg (no pixel is decoded) and counts the scans. False and why for
// anything else.
bool readJpegHeader(const uint8_t* data, size_t size, JpegHeader* header, std::string* why);

// An image of a frame as it must be before it is decoded: known format and encoding, a size within
// max_side_px, data_size equal to the data, raw rows inside the data, a JPEG whose header says the
// same size and channels as the message, finite pan/tilt/zoom.
bool checkImage(const ptzstereo::image_t& image, int max_side_px, std::string* why);
// Both images of a frame, each named in why ("right image: ...").
bool checkStereoFrame(const ptzstereo::stereo_frame_t& frame, int max_side_px, std::string* why);

// Both images width x height and in colour (BGR8 or RGB8), as a rig calibrated at that size
// needs; checked before a pixel is decoded, it bounds what a frame may cost. why names the side.
bool checkFrameMatchesRig(const ptzstereo::stereo_frame_t& frame, int width, int height,
                          std::string* why);
// A preview of such a rig (STEREO_PREVIEW): both images in colour, at least 16 px wide, no
// larger than width x height and of its shape to a pixel.
bool checkPreviewMatchesRig(const ptzstereo::stereo_frame_t& frame, int width, int height,
                            std::string* why);

// An image's pixels as BGR8 (or GRAY8) after checkImage (raw rows copied, a JPEG decoded whole,
// RGB8 turned to BGR8). Returns false and says why for anything inconsistent.
bool decodeImage(const ptzstereo::image_t& msg, cv::Mat* image, std::string* error);

}  // namespace ptz
