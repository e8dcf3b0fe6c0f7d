#include "sim/visca_server.hpp"

#include <poll.h>

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

ViscaCameras::ViscaCameras(const driver::ViscaModel& model, int first_port, SimRun* run)
    : server_(model, "127.0.0.1", first_port), run_(run) {}

void ViscaCameras::start() {
  thread_ = std::thread([this] { serve(); });
}

void ViscaCameras::stop() {
  quit_ = true;
  if (thread_.joinable()) thread_.join();
}

void ViscaCameras::serve() {
  while (!quit_) {
    pollfd fds[2] = {{server_.fd(Side::kLeft), POLLIN, 0}, {server_.fd(Side::kRight), POLLIN, 0}};
    if (::poll(fds, 2, 20) <= 0) continue;
    run_->withMotorsNow([this](Simulator& sim, double t_s) {
      const std::array<PtzPose, 2> now = {sim.plant().pose(Side::kLeft),
                                          sim.plant().pose(Side::kRight)};
      if (server_.serve(now, &setpoints_)) {
        int clamped = 0, rejected = 0;
        sim.command(t_s, setpoints_[0], setpoints_[1], &clamped, &rejected);
        ++setpoints_applied_;
        run_->noteServedCommand();
      }
    });
    packets_ = server_.packets();
    malformed_ = server_.malformed();
  }
}

}  // namespace ptz::sim
