#include "ptz_driver/emulators/visca_chain_emulator.hpp"

#include <algorithm>

namespace ptz::driver {

ViscaChainEmulator::ViscaChainEmulator(const ViscaModel& model, const PtzPlant::Params& plant,
                                       int cameras, const PtzPose& home)
    : model_(model),
      motors_(plant, home),
      cameras_(static_cast<size_t>(std::clamp(cameras, 1, 2))) {}

Bytes ViscaChainEmulator::feed(const uint8_t* data, size_t size, double now_s) {
  Bytes out;
  for (size_t i = 0; i < size; ++i) {
    partial_.push_back(data[i]);
    if (data[i] != 0xFF) continue;
    received_.push_back(partial_);
    const Bytes reply = handle(partial_, now_s);
    partial_.clear();
    if (!silent_) out.insert(out.end(), reply.begin(), reply.end());
  }
  const Bytes due = poll(now_s);
  out.insert(out.end(), due.begin(), due.end());
  return out;
}

Bytes ViscaChainEmulator::completion(size_t camera, int socket) const {
  return {static_cast<uint8_t>((cameras_[camera].address + 8) << 4),
          static_cast<uint8_t>(0x50 | socket), 0xFF};
}

Bytes ViscaChainEmulator::poll(double now_s) {
  Bytes out;
  for (size_t c = 0; c < cameras_.size(); ++c) {
    auto& running = cameras_[c].running;
    for (auto it = running.begin(); it != running.end();) {
      if (it->done_s < 0 || it->done_s > now_s) {
        ++it;
        continue;
      }
      const Bytes b = completion(c, it->socket);
      if (!silent_) out.insert(out.end(), b.begin(), b.end());
      it = running.erase(it);
    }
  }
  return out;
}

Bytes ViscaChainEmulator::releaseCompletion(int camera) {
  auto& running = cameras_[static_cast<size_t>(camera)].running;
  if (running.empty()) return {};
  const Bytes b = completion(static_cast<size_t>(camera), running.front().socket);
  running.erase(running.begin());
  return b;
}

Bytes ViscaChainEmulator::handle(const Bytes& p, double now_s) {
  if (p.size() >= 4 && p[0] == 0x88 && p[1] == 0x30) {  // Address Set: number the chain
    for (size_t c = 0; c < cameras_.size(); ++c) cameras_[c].address = p[2] + static_cast<int>(c);
    return {0x88, 0x30, static_cast<uint8_t>(p[2] + cameras_.size()), 0xFF};
  }
  if (p == Bytes{0x88, 0x01, 0x00, 0x01, 0xFF}) {  // IF_Clear: every camera's buffers emptied
    for (auto& c : cameras_) c.running.clear();
    return p;
  }
  for (size_t c = 0; c < cameras_.size(); ++c) {
    if (cameras_[c].address == 0 || p[0] != 0x80 + cameras_[c].address) continue;
    return handleCommand(c, p, now_s);
  }
  return p;  // nobody's: it comes back round the chain
}

Bytes ViscaChainEmulator::handleCommand(size_t c, const Bytes& p, double now_s) {
  Camera& cam = cameras_[c];
  const PtzPose now = pose(static_cast<int>(c), now_s);
  const ViscaCameraEmulator emulator(model_, cam.address);
  const bool is_command = p.size() > 1 && p[1] == 0x01;
  int socket = 0;
  if (is_command) {
    for (int s : {1, 2}) {
      const bool busy = std::any_of(cam.running.begin(), cam.running.end(),
                                    [s](const Running& r) { return r.socket == s; });
      if (!busy && socket == 0) socket = s;
    }
    if (socket == 0) return {static_cast<uint8_t>((cam.address + 8) << 4), 0x60, 0x03, 0xFF};
  }
  ViscaTarget target;
  const std::vector<Bytes> replies = emulator.handle(p, now, &target);
  if (target.pan_rad || target.tilt_rad || target.zoom) {
    const PtzPose& t = motors_.target(static_cast<int>(c));
    motors_.moveTo(static_cast<int>(c),
                   {target.pan_rad.value_or(t.pan_rad), target.tilt_rad.value_or(t.tilt_rad),
                    target.zoom.value_or(t.zoom)},
                   now_s);
    moves_.emplace_back(static_cast<int>(c), target);
  }
  // A command the camera takes: ACK on the free socket, completion later (see poll).
  if (is_command && replies.size() == 2) {
    cam.running.push_back({socket, completion_delay_s_ < 0 ? -1.0 : now_s + completion_delay_s_});
    return {static_cast<uint8_t>((cam.address + 8) << 4), static_cast<uint8_t>(0x40 | socket),
            0xFF};
  }
  Bytes out;
  for (const Bytes& r : replies) out.insert(out.end(), r.begin(), r.end());
  return out;
}

}  // namespace ptz::driver
