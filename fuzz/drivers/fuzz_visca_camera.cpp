// The camera end of VISCA: what ptz-sim --visca-port does with a datagram (sim/visca_server.cpp:
// visca_ip::unwrap, then the camera emulator's command parser) and the serial daisy chain the
// tests use, fed the same bytes. Input: one byte (bit 0: 4 or 5 pan nibbles), then the bytes.
// Properties: every answer is one well-formed VISCA reply from the camera's address; a target is
// finite and within what the command's nibbles can say; a position inquiry answers the pose.
#include <cmath>

#include "common/plant.hpp"
#include "fuzz/fuzz_support.hpp"
#include "ptz_driver/emulators/visca_camera_emulator.hpp"
#include "ptz_driver/emulators/visca_chain_emulator.hpp"

namespace driver = ptz::driver;

namespace {

driver::ViscaModel model(int pan_nibbles) {
  driver::ViscaModel m;
  m.name = "fuzz";
  m.pan_nibbles = pan_nibbles;
  m.pan_units_per_rad = (pan_nibbles == 5 ? 51.2 : 13.335) * 180 / M_PI;
  m.tilt_units_per_rad = m.pan_units_per_rad;
  m.pan_min_rad = -170 * M_PI / 180;
  m.pan_max_rad = -m.pan_min_rad;
  m.tilt_min_rad = -30 * M_PI / 180;
  m.tilt_max_rad = 90 * M_PI / 180;
  m.zoom.positions = {0, 16384};
  m.zoom.ratios = {1, 20};
  return m;
}

void checkPacket(const driver::ViscaCameraEmulator& camera, const driver::Bytes& packet) {
  const ptz::PtzPose now{0.5, -0.2, 3.0};
  driver::ViscaTarget target;
  const std::vector<driver::Bytes> replies = camera.handle(packet, now, &target);
  FUZZ_CHECK(!replies.empty(), "a packet without an answer");
  for (const driver::Bytes& r : replies) {
    driver::visca::ReplyParser parser;
    parser.feed(r.data(), r.size());
    const auto reply = parser.next();
    FUZZ_CHECK(reply && !parser.next() && parser.malformed() == 0 && reply->address == 1,
               "the camera's answer is not one reply from address 1");
    int32_t pan = 0, tilt = 0;
    if (driver::visca::decodePanTiltPosition(*reply, camera.model().pan_nibbles, &pan, &tilt)) {
      FUZZ_CHECK(pan == camera.model().panUnits(now.pan_rad) &&
                     tilt == camera.model().tiltUnits(now.tilt_rad),
                 "the position inquiry does not answer the pose");
    }
  }
  const double pan_limit_rad =
      (1 << (4 * camera.model().pan_nibbles - 1)) / camera.model().pan_units_per_rad;
  const double tilt_limit_rad = 32768 / camera.model().tilt_units_per_rad;
  if (target.pan_rad) {
    FUZZ_CHECK(std::isfinite(*target.pan_rad) && std::abs(*target.pan_rad) <= pan_limit_rad,
               "pan target " + std::to_string(*target.pan_rad));
  }
  if (target.tilt_rad) {
    FUZZ_CHECK(std::isfinite(*target.tilt_rad) && std::abs(*target.tilt_rad) <= tilt_limit_rad,
               "tilt target " + std::to_string(*target.tilt_rad));
  }
  if (target.zoom) {
    FUZZ_CHECK(*target.zoom >= 1 && *target.zoom <= 20,
               "zoom target " + std::to_string(*target.zoom));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const driver::ViscaModel m = model(data[0] & 1 ? 5 : 4);
  ++data;
  --size;

  const driver::ViscaCameraEmulator camera(m, 1);
  driver::visca_ip::Message datagram;
  std::string why;
  if (driver::visca_ip::unwrap(data, size, &datagram, &why) &&
      datagram.type != driver::visca_ip::kControl) {
    checkPacket(camera, datagram.payload);
  }
  checkPacket(camera, driver::Bytes(data, data + size));

  driver::ViscaChainEmulator chain(m, ptz::defaultPlantParams(), 2);
  chain.feed(data, size, 0.0);
  chain.poll(1.0);
  return 0;
}
