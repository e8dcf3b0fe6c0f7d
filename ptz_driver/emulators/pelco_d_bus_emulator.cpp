#include "ptz_driver/emulators/pelco_d_bus_emulator.hpp"

#include <algorithm>
#include <utility>

#include "ptz_driver/heads/pelco_d/pelco_d.hpp"

namespace ptz::driver {

PelcoDBusEmulator::PelcoDBusEmulator(PelcoModel model, const PtzPlant::Params& plant,
                                     std::vector<int> addresses, bool answers_queries,
                                     const PtzPose& home)
    : model_(std::move(model)),
      motors_(plant, home),
      addresses_(std::move(addresses)),
      answers_queries_(answers_queries) {}

Bytes PelcoDBusEmulator::feed(const uint8_t* data, size_t size, double now_s) {
  Bytes out;
  for (size_t i = 0; i < size; ++i) {
    if (partial_.empty() && data[i] != 0xFF) continue;  // out of step: wait for a sync byte
    partial_.push_back(data[i]);
    if (partial_.size() < 7) continue;
    const Bytes frame = std::exchange(partial_, Bytes());
    if (pelco_d::frame(frame[1], frame[2], frame[3], frame[4], frame[5]) != frame) {
      ++bad_checksums_;
      continue;
    }
    received_.push_back(frame);
    const auto it = std::find(addresses_.begin(), addresses_.end(), frame[1]);
    if (it == addresses_.end()) continue;  // another head's
    const Bytes reply = handle(static_cast<size_t>(it - addresses_.begin()), frame, now_s);
    out.insert(out.end(), reply.begin(), reply.end());
  }
  return out;
}

Bytes PelcoDBusEmulator::handle(size_t head, const Bytes& f, double now_s) {
  const PtzPose now = pose(static_cast<int>(head), now_s);
  const int value = f[4] << 8 | f[5];
  PtzPose t = motors_.target(static_cast<int>(head));
  if (f[2] == 0 && f[3] == 0 && f[4] == 0 && f[5] == 0) {
    t = now;  // stop: where it is
  } else if (f[2] == 0 && f[3] == 0x4B) {
    t.pan_rad = model_.panRad(value);
  } else if (f[2] == 0 && f[3] == 0x4D) {
    t.tilt_rad = model_.tiltRad(value);
  } else if (f[2] == 0 && f[3] == 0x4F) {
    t.zoom = model_.zoom.ratio(value);
  } else {
    if (f[2] == 0 && (f[3] == 0x51 || f[3] == 0x53 || f[3] == 0x55) && answers_queries_) {
      const int answer = f[3] == 0x51   ? model_.panCentideg(now.pan_rad)
                         : f[3] == 0x53 ? model_.tiltCentideg(now.tilt_rad)
                                        : model_.zoom.position(now.zoom);
      return pelco_d::frame(f[1], 0, static_cast<uint8_t>(f[3] + 8),
                            static_cast<uint8_t>(answer >> 8), static_cast<uint8_t>(answer & 0xFF));
    }
    return {};  // a query it does not answer, or a command it does not know
  }
  motors_.moveTo(static_cast<int>(head), t, now_s);
  moves_.emplace_back(static_cast<int>(head), t);
  return {};
}

}  // namespace ptz::driver
