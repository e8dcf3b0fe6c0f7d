// Recorded JPEG files published as they are (issue #18): ptz-camera need not decode and re-encode
// an image that is already the JPEG it would publish. Only the header is read (libjpeg, no pixel
// decoded) and checked the way consumers check a STEREO_FRAME image before they decode it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ptz::driver {

// A file larger than this is not read (a 4096 x 4096 colour JPEG at quality 100 is ~20 MB).
constexpr size_t kMaxImageFileBytes = 64u << 20;

// True when data may be published as a STEREO_FRAME image without decoding: a complete colour
// (3-component) JPEG (start and end markers, at most kMaxJpegScans scans, enough bytes for its
// blocks) whose header says width x height (0 x 0: any size up to kMaxImageSidePx), without an
// EXIF segment (a decoder would turn it by its orientation). Sets *width, *height; else false
// and why (then decode it instead).
bool checkPassThroughJpeg(const uint8_t* data, size_t size, int width, int height, int* out_width,
                          int* out_height, std::string* why);

// The whole file (at most kMaxImageFileBytes); false and why (naming the file) otherwise.
bool readFileBytes(const std::string& path, std::vector<uint8_t>* bytes, std::string* why);

}  // namespace ptz::driver
