#include "ptz_driver/heads/pelco_d/pelco_d.hpp"

#include <algorithm>
#include <cstdlib>

namespace ptz::driver::pelco_d {
namespace {
constexpr uint8_t kSync = 0xFF;
uint8_t checksum(const uint8_t* b) {
  return static_cast<uint8_t>((b[1] + b[2] + b[3] + b[4] + b[5]) & 0xFF);
}
}  // namespace

Bytes frame(int address, uint8_t command1, uint8_t command2, uint8_t data1, uint8_t data2) {
  Bytes b = {kSync, static_cast<uint8_t>(address), command1, command2, data1, data2, 0};
  b[6] = checksum(b.data());
  return b;
}

Bytes stop(int address) {
  return frame(address, 0, 0, 0, 0);
}

Bytes panTilt(int address, int pan_speed, int tilt_speed) {
  uint8_t command2 = 0;
  if (pan_speed > 0) command2 |= 0x02;   // right
  if (pan_speed < 0) command2 |= 0x04;   // left
  if (tilt_speed > 0) command2 |= 0x08;  // up
  if (tilt_speed < 0) command2 |= 0x10;  // down
  return frame(address, 0, command2, static_cast<uint8_t>(std::min(std::abs(pan_speed), 0x3F)),
               static_cast<uint8_t>(std::min(std::abs(tilt_speed), 0x3F)));
}

namespace {
Bytes withValue(int address, uint8_t command2, int value) {
  const int v = std::clamp(value, 0, 0xFFFF);
  return frame(address, 0, command2, static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v & 0xFF));
}
}  // namespace

Bytes setPanPosition(int address, int centidegrees) {
  return withValue(address, 0x4B, std::clamp(centidegrees, 0, 35999));
}
Bytes setTiltPosition(int address, int centidegrees) {
  return withValue(address, 0x4D, std::clamp(centidegrees, 0, 35999));
}
Bytes setZoomPosition(int address, int position) {
  return withValue(address, 0x4F, position);
}
Bytes queryPan(int address) {
  return frame(address, 0, 0x51, 0, 0);
}
Bytes queryTilt(int address) {
  return frame(address, 0, 0x53, 0, 0);
}
Bytes queryZoom(int address) {
  return frame(address, 0, 0x55, 0, 0);
}

void ReplyParser::feed(const uint8_t* data, size_t size) {
  for (size_t i = 0; i < size; ++i) {
    if (partial_.empty() && data[i] != kSync) {
      ++skipped_;
      continue;
    }
    partial_.push_back(data[i]);
    if (partial_.size() < 7) continue;
    if (checksum(partial_.data()) == partial_[6]) {
      ready_.push_back({partial_[1], partial_[3], partial_[4] << 8 | partial_[5]});
      partial_.clear();
      continue;
    }
    // Out of step: resynchronise on the next sync byte inside what we have.
    ++bad_checksums_;
    auto it = std::find(partial_.begin() + 1, partial_.end(), kSync);
    skipped_ += it - partial_.begin();
    partial_.erase(partial_.begin(), it);
  }
}

std::optional<Reply> ReplyParser::next() {
  if (ready_.empty()) return std::nullopt;
  Reply r = ready_.front();
  ready_.pop_front();
  return r;
}

}  // namespace ptz::driver::pelco_d
