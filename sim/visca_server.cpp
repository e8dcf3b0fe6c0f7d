#include "sim/visca_server.hpp"

namespace ptz::sim {

ViscaServer::ViscaServer(const driver::ViscaModel& model, const std::string& host, int first_port)
    : cameras_{driver::ViscaCameraEmulator(model, 1), driver::ViscaCameraEmulator(model, 1)} {
  for (int i = 0; i < 2; ++i) {
    sockets_[static_cast<size_t>(i)] = std::make_unique<driver::UdpSocket>();
    sockets_[static_cast<size_t>(i)]->bind(host, first_port + i);
  }
}

bool ViscaServer::serve(const std::array<PtzPose, 2>& now, std::array<PtzPose, 2>* setpoints) {
  bool changed = false;
  for (size_t i = 0; i < 2; ++i) {
    driver::Bytes datagram;
    while (sockets_[i]->receive(&datagram)) {
      ++packets_;
      driver::visca_ip::Message m;
      std::string error;
      if (!driver::visca_ip::unwrap(datagram.data(), datagram.size(), &m, &error)) {
        ++malformed_;
        continue;
      }
      if (m.type == driver::visca_ip::kControl) {  // RESET of the sequence number
        sockets_[i]->sendToLastPeer(
            driver::visca_ip::wrap(driver::visca_ip::kControlReply, m.sequence, {0x01}));
        continue;
      }
      driver::ViscaTarget target;
      for (const auto& reply : cameras_[i].handle(m.payload, now[i], &target)) {
        sockets_[i]->sendToLastPeer(
            driver::visca_ip::wrap(driver::visca_ip::kReply, m.sequence, reply));
      }
      PtzPose& sp = (*setpoints)[i];
      if (target.pan_rad) sp.pan_rad = *target.pan_rad;
      if (target.tilt_rad) sp.tilt_rad = *target.tilt_rad;
      if (target.zoom) sp.zoom = *target.zoom;
      changed |= target.pan_rad || target.tilt_rad || target.zoom;
    }
  }
  return changed;
}

}  // namespace ptz::sim
