#include "ptz_driver/cameras/sources/jpeg_file.hpp"

#include <fstream>

#include "common/transport/message_check.hpp"

namespace ptz::driver {
namespace {

// An APP1 segment saying "Exif" before the first scan (segments walked by their lengths).
bool hasExif(const uint8_t* data, size_t size) {
  size_t i = 2;  // after FF D8
  while (i + 4 <= size && data[i] == 0xFF) {
    const uint8_t marker = data[i + 1];
    if (marker == 0xFF) {  // fill byte
      ++i;
      continue;
    }
    if (marker == 0xDA || marker == 0xD9) return false;  // start of scan, end of image
    const size_t length = (static_cast<size_t>(data[i + 2]) << 8) | data[i + 3];
    if (marker == 0xE1 && length >= 8 && i + 10 <= size &&
        std::string(reinterpret_cast<const char*>(data + i + 4), 4) == "Exif") {
      return true;
    }
    i += 2 + length;
  }
  return false;
}

// Ends with the end-of-image marker, maybe followed by zero padding (some cameras pad).
bool endsWithEoi(const uint8_t* data, size_t size) {
  while (size > 2 && data[size - 1] == 0) --size;
  return size >= 4 && data[size - 2] == 0xFF && data[size - 1] == 0xD9;
}

}  // namespace

bool checkPassThroughJpeg(const uint8_t* data, size_t size, int width, int height, int* out_width,
                          int* out_height, std::string* why) {
  JpegHeader h;
  if (!readJpegHeader(data, size, &h, why)) return false;
  const auto text = [](int w, int ht) { return std::to_string(w) + "x" + std::to_string(ht); };
  if (h.width <= 0 || h.height <= 0 || h.width > kMaxImageSidePx || h.height > kMaxImageSidePx) {
    *why = "JPEG of " + text(h.width, h.height) + " outside 1.." + std::to_string(kMaxImageSidePx);
    return false;
  }
  if (width > 0 && (h.width != width || h.height != height)) {
    *why = "JPEG of " + text(h.width, h.height) + ", published at " + text(width, height);
    return false;
  }
  if (h.channels != 3) {
    *why = "JPEG has " + std::to_string(h.channels) + " components, not 3 (colour)";
    return false;
  }
  if (h.scans > kMaxJpegScans) {
    *why = "JPEG has " + std::to_string(h.scans) + " scans";
    return false;
  }
  // As checkImage: every 8x8 luma block takes at least one bit.
  const size_t min_bytes = static_cast<size_t>((h.width + 7) / 8) * ((h.height + 7) / 8) / 8;
  if (size < min_bytes) {
    *why = "JPEG of " + std::to_string(size) + " bytes cannot hold " + text(h.width, h.height);
    return false;
  }
  if (!endsWithEoi(data, size)) {
    *why = "JPEG truncated (no end-of-image marker)";
    return false;
  }
  if (hasExif(data, size)) {
    *why = "JPEG with EXIF (an orientation would turn it)";
    return false;
  }
  *out_width = h.width;
  *out_height = h.height;
  return true;
}

bool readFileBytes(const std::string& path, std::vector<uint8_t>* bytes, std::string* why) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) {
    *why = "image file '" + path + "' cannot be read";
    return false;
  }
  const std::streamoff size = in.tellg();
  if (size < 0 || static_cast<uint64_t>(size) > kMaxImageFileBytes) {
    *why = "image file '" + path + "' is larger than " + std::to_string(kMaxImageFileBytes >> 20) +
           " MB";
    return false;
  }
  bytes->resize(static_cast<size_t>(size));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes->data()), size)) {
    *why = "image file '" + path + "' cannot be read";
    return false;
  }
  return true;
}

}  // namespace ptz::driver
