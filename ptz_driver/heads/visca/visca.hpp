// Sony VISCA (serial and over IP) as bytes: the commands ptz-driver sends, the replies it reads,
// and the 8-byte header of VISCA over IP. No I/O here; transports live elsewhere.
// References: Sony EVI-D70 / EVI-H100S / SRG-300SE technical manuals (command lists) and the
// VISCA-over-IP section of the SRG series manual (header, sequence numbers, control commands).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "ptz_driver/io/bytes.hpp"

namespace ptz::driver {

namespace visca {

// Commands to the camera at `address` (1..7): header 0x80 | address, terminator 0xFF.
// Pan-tilt drive absolute: 8x 01 06 02 VV WW 0Y.. 0Z.. FF, the pan position in 4 or 5 nibbles
// (two's complement of 16 or 20 bits), the tilt position in 4.
Bytes panTiltAbsolute(int address, int pan_speed, int tilt_speed, int32_t pan_units,
                      int32_t tilt_units, int pan_nibbles);
Bytes panTiltStop(int address, int pan_speed, int tilt_speed);  // 8x 01 06 01 VV WW 03 03 FF
Bytes zoomDirect(int address, int position);                    // 8x 01 04 47 0p 0q 0r 0s FF
Bytes zoomStop(int address);                                    // 8x 01 04 07 00 FF
Bytes panTiltPositionInquiry(int address);                      // 8x 09 06 12 FF
Bytes zoomPositionInquiry(int address);                         // 8x 09 04 47 FF
Bytes ifClear();                                                // 88 01 00 01 FF (broadcast)
Bytes addressSet();                                             // 88 30 01 FF (broadcast)

// Error codes of an error reply (y0 6z EE FF).
enum ErrorCode : uint8_t {
  kMessageLength = 0x01,
  kSyntax = 0x02,
  kBufferFull = 0x03,
  kCanceled = 0x04,
  kNoSocket = 0x05,
  kNotExecutable = 0x41,
};
std::string errorName(int code);

struct Reply {
  // kAddress and kIfClear: the broadcasts Address Set and IF_Clear coming back round the chain.
  enum class Kind { kAck, kCompletion, kError, kInquiry, kAddress, kIfClear, kOther };
  Kind kind = Kind::kOther;
  int address = 0;  // of the camera that answered (header (address + 8) << 4)
  int socket = 0;   // ACK, completion, error
  int error = 0;    // error replies
  Bytes bytes;      // the whole packet, header to terminator
};

// Splits a byte stream into replies at the terminator 0xFF. Garbage (a packet without a reply
// header, longer than 16 bytes, or a lone terminator) is counted and skipped; nothing it is fed
// can make it crash or grow without bound.
class ReplyParser {
 public:
  void feed(const uint8_t* data, size_t size);
  std::optional<Reply> next();
  int64_t malformed() const { return malformed_; }
  int64_t garbage() const { return malformed_; }  // what a serial line counts as malformed

 private:
  Bytes partial_;
  std::deque<Reply> ready_;
  int64_t malformed_ = 0;
};

// Inquiry replies: y0 50 0w 0w 0w 0w 0z 0z 0z 0z FF (pan in pan_nibbles), y0 50 0p 0q 0r 0s FF.
bool decodePanTiltPosition(const Reply& reply, int pan_nibbles, int32_t* pan_units,
                           int32_t* tilt_units);
bool decodeZoomPosition(const Reply& reply, int* position);

// The nibbles of a value, most significant first, two's complement over 4 * count bits.
void putNibbles(Bytes* out, int32_t value, int count);
int32_t readNibbles(const uint8_t* in, int count, bool is_signed);

}  // namespace visca

// VISCA over IP (Sony, UDP port 52381): an 8-byte header before each VISCA packet.
namespace visca_ip {

enum PayloadType : uint16_t {
  kCommand = 0x0100,
  kInquiry = 0x0110,
  kReply = 0x0111,
  kDeviceSetting = 0x0120,
  kControl = 0x0200,
  kControlReply = 0x0201,
};

struct Message {
  uint16_t type = 0;
  uint32_t sequence = 0;
  Bytes payload;
};

// type (2 bytes), payload length (2), sequence number (4), all big-endian, then the payload.
Bytes wrap(uint16_t type, uint32_t sequence, const Bytes& payload);
// False (with the reason) for a datagram that is not one well-formed message.
bool unwrap(const uint8_t* data, size_t size, Message* message, std::string* error);
// The control command RESET (payload 01): the camera's expected sequence number goes to 0.
Bytes resetSequence(uint32_t sequence);

}  // namespace visca_ip

}  // namespace ptz::driver
