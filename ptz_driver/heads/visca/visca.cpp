#include "ptz_driver/heads/visca/visca.hpp"

#include <algorithm>

namespace ptz::driver {
namespace visca {
namespace {

constexpr uint8_t kTerminator = 0xFF;
constexpr size_t kMaxPacket = 16;  // the longest VISCA message

uint8_t header(int address) {
  return static_cast<uint8_t>(0x80 | (std::clamp(address, 1, 7)));
}

}  // namespace

void putNibbles(Bytes* out, int32_t value, int count) {
  const uint32_t bits = static_cast<uint32_t>(value);
  for (int i = count - 1; i >= 0; --i)
    out->push_back(static_cast<uint8_t>((bits >> (4 * i)) & 0xF));
}

int32_t readNibbles(const uint8_t* in, int count, bool is_signed) {
  uint32_t v = 0;
  for (int i = 0; i < count; ++i) v = (v << 4) | (in[i] & 0xF);
  const int bits = 4 * count;
  if (is_signed && bits < 32 && (v & (1u << (bits - 1)))) v |= ~0u << bits;
  return static_cast<int32_t>(v);
}

Bytes panTiltAbsolute(int address, int pan_speed, int tilt_speed, int32_t pan_units,
                      int32_t tilt_units, int pan_nibbles) {
  Bytes b = {header(address),
             0x01,
             0x06,
             0x02,
             static_cast<uint8_t>(pan_speed),
             static_cast<uint8_t>(tilt_speed)};
  putNibbles(&b, pan_units, pan_nibbles);
  putNibbles(&b, tilt_units, 4);
  b.push_back(kTerminator);
  return b;
}

Bytes panTiltStop(int address, int pan_speed, int tilt_speed) {
  return {header(address),
          0x01,
          0x06,
          0x01,
          static_cast<uint8_t>(pan_speed),
          static_cast<uint8_t>(tilt_speed),
          0x03,
          0x03,
          kTerminator};
}

Bytes zoomDirect(int address, int position) {
  Bytes b = {header(address), 0x01, 0x04, 0x47};
  putNibbles(&b, position, 4);
  b.push_back(kTerminator);
  return b;
}

Bytes zoomStop(int address) {
  return {header(address), 0x01, 0x04, 0x07, 0x00, kTerminator};
}
Bytes panTiltPositionInquiry(int address) {
  return {header(address), 0x09, 0x06, 0x12, kTerminator};
}
Bytes zoomPositionInquiry(int address) {
  return {header(address), 0x09, 0x04, 0x47, kTerminator};
}
Bytes ifClear() {
  return {0x88, 0x01, 0x00, 0x01, kTerminator};
}
Bytes addressSet() {
  return {0x88, 0x30, 0x01, kTerminator};
}

std::string errorName(int code) {
  switch (code) {
    case kMessageLength:
      return "message length error";
    case kSyntax:
      return "syntax error";
    case kBufferFull:
      return "command buffer full";
    case kCanceled:
      return "command canceled";
    case kNoSocket:
      return "no socket (to cancel)";
    case kNotExecutable:
      return "command not executable";
    default:
      return "unknown error " + std::to_string(code);
  }
}

void ReplyParser::feed(const uint8_t* data, size_t size) {
  for (size_t i = 0; i < size; ++i) {
    const uint8_t b = data[i];
    if (b != kTerminator) {
      // A reply starts with a header byte (bit 7 set); anything before one is garbage.
      if (partial_.empty() && !(b & 0x80)) {
        ++malformed_;
        continue;
      }
      if (partial_.size() >= kMaxPacket - 1) {  // no room left for the terminator
        ++malformed_;
        partial_.clear();
        if (!(b & 0x80)) continue;
      }
      partial_.push_back(b);
      continue;
    }
    if (partial_.size() < 2) {
      ++malformed_;
      partial_.clear();
      continue;
    }
    partial_.push_back(b);
    Reply r;
    r.bytes = partial_;
    partial_.clear();
    const uint8_t h = r.bytes[0], k = r.bytes[1];
    if (h == 0x88 && (k == 0x30 || k == 0x01)) {  // a broadcast coming back round the chain
      r.kind = k == 0x30 ? Reply::Kind::kAddress : Reply::Kind::kIfClear;
      ready_.push_back(std::move(r));
      continue;
    }
    if ((h & 0x8F) != 0x80 || (h >> 4) < 9) {
      ++malformed_;
      continue;
    }
    r.address = (h >> 4) - 8;
    r.socket = k & 0x0F;
    switch (k & 0xF0) {
      case 0x40:
        r.kind = Reply::Kind::kAck;
        break;
      case 0x50:
        r.kind = r.bytes.size() == 3 ? Reply::Kind::kCompletion : Reply::Kind::kInquiry;
        break;
      case 0x60:
        r.kind = Reply::Kind::kError;
        r.error = r.bytes.size() >= 4 ? r.bytes[2] : 0;
        break;
      default:
        r.kind = Reply::Kind::kOther;
    }
    ready_.push_back(std::move(r));
  }
}

std::optional<Reply> ReplyParser::next() {
  if (ready_.empty()) return std::nullopt;
  Reply r = std::move(ready_.front());
  ready_.pop_front();
  return r;
}

bool decodePanTiltPosition(const Reply& reply, int pan_nibbles, int32_t* pan_units,
                           int32_t* tilt_units) {
  const size_t expected = 2 + static_cast<size_t>(pan_nibbles) + 4 + 1;
  if (reply.kind != Reply::Kind::kInquiry || reply.bytes.size() != expected) return false;
  for (size_t i = 2; i + 1 < expected; ++i) {
    if (reply.bytes[i] & 0xF0) return false;  // nibbles only
  }
  *pan_units = readNibbles(&reply.bytes[2], pan_nibbles, true);
  *tilt_units = readNibbles(&reply.bytes[2 + static_cast<size_t>(pan_nibbles)], 4, true);
  return true;
}

bool decodeZoomPosition(const Reply& reply, int* position) {
  if (reply.kind != Reply::Kind::kInquiry || reply.bytes.size() != 7) return false;
  for (size_t i = 2; i < 6; ++i) {
    if (reply.bytes[i] & 0xF0) return false;
  }
  *position = readNibbles(&reply.bytes[2], 4, false);
  return true;
}

}  // namespace visca

namespace visca_ip {

Bytes wrap(uint16_t type, uint32_t sequence, const Bytes& payload) {
  const auto length = static_cast<uint16_t>(payload.size());
  Bytes b(8 + payload.size());
  b[0] = static_cast<uint8_t>(type >> 8);
  b[1] = static_cast<uint8_t>(type);
  b[2] = static_cast<uint8_t>(length >> 8);
  b[3] = static_cast<uint8_t>(length);
  for (int i = 0; i < 4; ++i)
    b[4 + static_cast<size_t>(i)] = static_cast<uint8_t>(sequence >> (24 - 8 * i));
  std::copy(payload.begin(), payload.end(), b.begin() + 8);
  return b;
}

bool unwrap(const uint8_t* data, size_t size, Message* m, std::string* error) {
  if (size < 8) {
    *error = "datagram of " + std::to_string(size) + " bytes is shorter than the 8-byte header";
    return false;
  }
  m->type = static_cast<uint16_t>(data[0] << 8 | data[1]);
  const size_t length = static_cast<size_t>(data[2] << 8 | data[3]);
  m->sequence = static_cast<uint32_t>(data[4]) << 24 | static_cast<uint32_t>(data[5]) << 16 |
                static_cast<uint32_t>(data[6]) << 8 | data[7];
  if (length != size - 8 || length == 0 || length > 16) {
    *error = "payload length " + std::to_string(length) + " but " + std::to_string(size - 8) +
             " bytes follow the header";
    return false;
  }
  switch (m->type) {
    case kCommand:
    case kInquiry:
    case kReply:
    case kDeviceSetting:
    case kControl:
    case kControlReply:
      break;
    default:
      *error = "unknown payload type " + std::to_string(m->type);
      return false;
  }
  m->payload.assign(data + 8, data + size);
  return true;
}

Bytes resetSequence(uint32_t sequence) {
  return wrap(kControl, sequence, {0x01});
}

}  // namespace visca_ip
}  // namespace ptz::driver
