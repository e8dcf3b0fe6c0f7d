// Pelco-D as bytes: 7-byte frames FF, address, command 1, command 2, data 1, data 2, checksum
// (the sum of bytes 2 to 6 modulo 256). Motion commands set pan/tilt speeds (0..0x3F) and
// directions; the extended commands 0x4B/0x4D/0x4F set absolute pan, tilt (hundredths of a
// degree) and zoom positions, and 0x51/0x53/0x55 query them (replies 0x59/0x5B/0x5D) on the
// heads that implement them; many cheap heads do not, and then the driver cannot report where
// the head is (see ptz_driver/heads/pelco_d/README.md).
#pragma once

#include <cstdint>
#include <deque>
#include <optional>

#include "ptz_driver/io/bytes.hpp"

namespace ptz::driver::pelco_d {

Bytes frame(int address, uint8_t command1, uint8_t command2, uint8_t data1, uint8_t data2);
Bytes stop(int address);
// Signed speeds: > 0 pans right / tilts up, < 0 left / down; |speed| up to 0x3F.
Bytes panTilt(int address, int pan_speed, int tilt_speed);
Bytes setPanPosition(int address, int centidegrees);   // 0..35999
Bytes setTiltPosition(int address, int centidegrees);  // 0..35999 (head-specific meaning)
Bytes setZoomPosition(int address, int position);      // 0..65535
Bytes queryPan(int address);
Bytes queryTilt(int address);
Bytes queryZoom(int address);

struct Reply {
  int address = 0;
  uint8_t command2 = 0;  // 0x59 pan, 0x5B tilt, 0x5D zoom position; 0x00 a general response
  int value = 0;         // data1 << 8 | data2
};

// Frames replies out of a byte stream: syncs on 0xFF, checks the checksum, counts what is bad.
class ReplyParser {
 public:
  void feed(const uint8_t* data, size_t size);
  std::optional<Reply> next();
  int64_t badChecksums() const { return bad_checksums_; }
  int64_t skippedBytes() const { return skipped_; }
  int64_t garbage() const { return bad_checksums_ + skipped_; }  // a serial line's malformed

 private:
  Bytes partial_;
  std::deque<Reply> ready_;
  int64_t bad_checksums_ = 0, skipped_ = 0;
};

}  // namespace ptz::driver::pelco_d
