// The Pelco-D bytes of an RS-485 bus: pelco_d::ReplyParser as ptz-driver reads replies (fed in
// pieces, as reads return them), and the head end of the bus (the emulator the tests drive) fed
// the same bytes as commands. Input: one byte choosing the piece size, then the bytes.
// Properties: every byte is accounted for (skipped, in a good frame, or still pending: at most
// 6); every reply is a frame with a good checksum; what the emulated heads answer parses clean.
#include <algorithm>

#include "common/plant.hpp"
#include "fuzz/fuzz_support.hpp"
#include "ptz_driver/emulators/pelco_d_bus_emulator.hpp"
#include "ptz_driver/heads/pelco_d/pelco_d.hpp"

namespace pelco_d = ptz::driver::pelco_d;

namespace {

ptz::driver::PelcoModel model() {
  ptz::driver::PelcoModel m;
  m.name = "fuzz";
  m.pan_min_rad = -3.0;
  m.pan_max_rad = 3.0;
  m.tilt_min_rad = -0.5;
  m.tilt_max_rad = 1.5;
  m.zoom.positions = {0, 65535};
  m.zoom.ratios = {1, 10};
  return m;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ptz::fuzz::Pieces in = ptz::fuzz::piecesOf(data, size);
  if (in.size == 0) return 0;

  pelco_d::ReplyParser parser;
  int64_t replies = 0;
  in.forEach([&](const uint8_t* bytes, size_t n) {
    parser.feed(bytes, n);
    while (auto r = parser.next()) {
      FUZZ_CHECK(
          r->address >= 0 && r->address <= 255 && r->value >= 0 && r->value <= 0xFFFF,
          "reply address " + std::to_string(r->address) + " value " + std::to_string(r->value));
      ++replies;
    }
  });
  const int64_t bytes_in = static_cast<int64_t>(in.size);
  const int64_t accounted = parser.skippedBytes() + 7 * replies;
  FUZZ_CHECK(accounted <= bytes_in && accounted + 6 >= bytes_in,
             std::to_string(bytes_in) + " bytes but " + std::to_string(parser.skippedBytes()) +
                 " skipped and " + std::to_string(replies) + " frames");

  ptz::driver::PelcoDBusEmulator heads(model(), ptz::defaultPlantParams(), {1, 2}, true);
  pelco_d::ReplyParser answers;
  double now_s = 0;
  in.forEach([&](const uint8_t* bytes, size_t n) {
    const ptz::driver::Bytes out = heads.feed(bytes, n, now_s);
    answers.feed(out.data(), out.size());
    now_s += 0.01;
  });
  FUZZ_CHECK(answers.badChecksums() == 0 && answers.skippedBytes() == 0,
             "the emulated heads answered bytes that are not clean frames");
  return 0;
}
