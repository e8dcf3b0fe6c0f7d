// An RS-485 bus as the Pelco-D heads see it, for SerialServer: half duplex. A head's reply
// occupies the line for reply_s after its query came (at 2400 baud a 7-byte frame is 29 ms);
// bytes the controller sends meanwhile collide with it: they never reach a head whole and the
// reply arrives garbled. A pty alone delivers both intact, which hides a controller that talks
// into a reply.
#pragma once

#include <cstdint>

#include "ptz_driver/emulators/pelco_d_bus_emulator.hpp"

namespace ptz::test {

class HalfDuplexBus {
 public:
  HalfDuplexBus(driver::PelcoDBusEmulator* heads, double reply_s)
      : heads_(heads), reply_s_(reply_s) {}

  driver::Bytes feed(const uint8_t* data, size_t size, double now_s) {
    for (size_t i = 0; i < size; ++i) {
      if (!reply_.empty()) {  // the line is busy with the reply: this byte collides
        ++collided_bytes_;
        garbled_ = true;
        continue;
      }
      reply_ = heads_->feed(data + i, 1, now_s);
      reply_at_s_ = now_s + reply_s_;
    }
    if (reply_.empty() || now_s < reply_at_s_) return {};
    driver::Bytes out;
    out.swap(reply_);
    if (garbled_) {
      for (uint8_t& b : out) b ^= 0x5A;
    }
    garbled_ = false;
    return out;
  }
  // Bytes from the controller lost in collisions so far.
  int64_t collidedBytes() const { return collided_bytes_; }
  driver::PelcoDBusEmulator& heads() { return *heads_; }

 private:
  driver::PelcoDBusEmulator* heads_;
  double reply_s_;
  driver::Bytes reply_;  // on its way
  double reply_at_s_ = 0;
  bool garbled_ = false;
  int64_t collided_bytes_ = 0;
};

}  // namespace ptz::test
