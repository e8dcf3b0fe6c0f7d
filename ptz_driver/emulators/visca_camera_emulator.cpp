#include "ptz_driver/emulators/visca_camera_emulator.hpp"

#include <algorithm>

namespace ptz::driver {

Bytes ViscaCameraEmulator::reply(std::initializer_list<uint8_t> body) const {
  Bytes b(body.size() + 2);
  b[0] = static_cast<uint8_t>((address_ + 8) << 4);
  std::copy(body.begin(), body.end(), b.begin() + 1);
  b.back() = 0xFF;
  return b;
}

std::vector<Bytes> ViscaCameraEmulator::handle(const Bytes& p, const PtzPose& now,
                                               ViscaTarget* target) const {
  *target = {};
  if (p.size() < 3 || p.back() != 0xFF || (p[0] & 0xF0) != 0x80) {
    return {reply({0x60, visca::kMessageLength})};
  }
  const size_t n = p.size();
  // Commands: 8x 01 ...; ACK on socket 1, then completion.
  if (p[1] == 0x01 && n >= 5 && p[2] == 0x06 && p[3] == 0x02 &&
      n == static_cast<size_t>(6 + model_.pan_nibbles + 4 + 1)) {
    target->pan_rad = model_.panRad(visca::readNibbles(&p[6], model_.pan_nibbles, true));
    target->tilt_rad = model_.tiltRad(
        visca::readNibbles(&p[6 + static_cast<size_t>(model_.pan_nibbles)], 4, true));
    return {reply({0x41}), reply({0x51})};
  }
  if (p[1] == 0x01 && n == 9 && p[2] == 0x06 && p[3] == 0x01) {  // stop: hold where it is
    target->pan_rad = now.pan_rad;
    target->tilt_rad = now.tilt_rad;
    return {reply({0x41}), reply({0x51})};
  }
  if (p[1] == 0x01 && n == 9 && p[2] == 0x04 && p[3] == 0x47) {
    target->zoom = model_.zoomRatio(visca::readNibbles(&p[4], 4, false));
    return {reply({0x41}), reply({0x51})};
  }
  if (p[1] == 0x01 && n == 6 && p[2] == 0x04 && p[3] == 0x07 && p[4] == 0x00) {
    target->zoom = now.zoom;
    return {reply({0x41}), reply({0x51})};
  }
  // Inquiries: 8x 09 ...
  if (p[1] == 0x09 && n == 5 && p[2] == 0x06 && p[3] == 0x12) {
    Bytes r = {static_cast<uint8_t>((address_ + 8) << 4), 0x50};
    visca::putNibbles(&r, model_.panUnits(now.pan_rad), model_.pan_nibbles);
    visca::putNibbles(&r, model_.tiltUnits(now.tilt_rad), 4);
    r.push_back(0xFF);
    return {r};
  }
  if (p[1] == 0x09 && n == 5 && p[2] == 0x04 && p[3] == 0x47) {
    Bytes r = {static_cast<uint8_t>((address_ + 8) << 4), 0x50};
    visca::putNibbles(&r, model_.zoomPosition(now.zoom), 4);
    r.push_back(0xFF);
    return {r};
  }
  return {reply({0x60, visca::kSyntax})};
}

}  // namespace ptz::driver
