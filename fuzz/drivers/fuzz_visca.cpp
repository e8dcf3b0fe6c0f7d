// What ptz-driver reads from a VISCA camera: the serial byte stream through visca::ReplyParser
// (fed in pieces, as reads return them) and the inquiry decoders, and a VISCA-over-IP datagram
// through visca_ip::unwrap. Input: one byte choosing the piece size, then the bytes. Properties:
// every reply is a packet of 3..16 bytes from a header byte to the terminator; decoded positions
// fit their nibbles and encode back to the reply; an unwrapped datagram wraps back to itself.
#include <vector>

#include "fuzz/fuzz_support.hpp"
#include "ptz_driver/heads/visca/visca.hpp"

namespace visca = ptz::driver::visca;
namespace visca_ip = ptz::driver::visca_ip;

namespace {

std::string hex(const ptz::driver::Bytes& b) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (uint8_t v : b) s += std::string{digits[v >> 4], digits[v & 15], ' '};
  return s;
}

void checkReply(const visca::Reply& r) {
  const auto& b = r.bytes;
  FUZZ_CHECK(b.size() >= 3 && b.size() <= 16, "reply of " + std::to_string(b.size()) + " bytes");
  FUZZ_CHECK((b.front() & 0x80) && b.back() == 0xFF, "reply not header to terminator: " + hex(b));
  for (size_t i = 0; i + 1 < b.size(); ++i) {
    FUZZ_CHECK(b[i] != 0xFF, "a terminator inside a reply: " + hex(b));
  }
  for (int nibbles : {4, 5}) {
    int32_t pan = 0, tilt = 0;
    if (!visca::decodePanTiltPosition(r, nibbles, &pan, &tilt)) continue;
    const int32_t pan_limit = 1 << (4 * nibbles - 1);
    FUZZ_CHECK(pan >= -pan_limit && pan < pan_limit && tilt >= -32768 && tilt < 32768,
               "pan " + std::to_string(pan) + " tilt " + std::to_string(tilt) + " from " + hex(b));
    ptz::driver::Bytes again = {b[0], b[1]};
    visca::putNibbles(&again, pan, nibbles);
    visca::putNibbles(&again, tilt, 4);
    again.push_back(0xFF);
    FUZZ_CHECK(again == b, "pan/tilt do not encode back: " + hex(b) + "-> " + hex(again));
  }
  int zoom = 0;
  if (visca::decodeZoomPosition(r, &zoom)) {
    FUZZ_CHECK(zoom >= 0 && zoom <= 0xFFFF, "zoom " + std::to_string(zoom) + " from " + hex(b));
    ptz::driver::Bytes again = {b[0], b[1]};
    visca::putNibbles(&again, zoom, 4);
    again.push_back(0xFF);
    FUZZ_CHECK(again == b, "zoom does not encode back: " + hex(b));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ptz::fuzz::Pieces in = ptz::fuzz::piecesOf(data, size);
  if (in.size == 0) return 0;

  visca::ReplyParser parser;
  size_t replies = 0;
  in.forEach([&](const uint8_t* bytes, size_t n) {
    parser.feed(bytes, n);
    while (auto r = parser.next()) {
      checkReply(*r);
      ++replies;
    }
  });
  FUZZ_CHECK(replies <= in.size / 3,
             std::to_string(replies) + " replies from " + std::to_string(in.size) + " bytes");

  visca_ip::Message m;
  std::string why;
  if (visca_ip::unwrap(in.data, in.size, &m, &why)) {
    const ptz::driver::Bytes again = visca_ip::wrap(m.type, m.sequence, m.payload);
    FUZZ_CHECK(again == ptz::driver::Bytes(in.data, in.data + in.size),
               "unwrap + wrap changed the bytes");
  } else {
    FUZZ_CHECK(!why.empty(), "a refused datagram without a reason");
  }
  return 0;
}
