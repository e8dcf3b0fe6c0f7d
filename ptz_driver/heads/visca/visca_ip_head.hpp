// One PTZ camera over VISCA over IP: replies matched to requests by sequence number; the rest
// (commands for what changed, inquiries decoded into a pose, round trips, errors by name,
// "command buffer full", the confirmed stop) is ViscaHeadCore, shared with serial VISCA.
// Requests not answered within the timeout are forgotten: a lost command is sent again.
#pragma once

#include <map>
#include <optional>
#include <string>

#include "ptz_driver/heads/common/head.hpp"
#include "ptz_driver/heads/visca/visca_head_core.hpp"
#include "ptz_driver/io/udp.hpp"

namespace ptz::driver {

class ViscaIpHead : public PtzHead {
 public:
  // Connects to host:port; throws std::runtime_error naming it when the address is bad.
  ViscaIpHead(ViscaModel model, const std::string& host, int port, int address = 1);

  // Resets the camera's sequence number (Sony's RESET control command).
  void start(double now_s) override;
  // Moves to pose (clamped to the model's range); only sends what changed by a unit or more.
  void command(const PtzPose& pose, double now_s) override;
  // Stops pan, tilt and zoom where they are. Returns whether the camera answered both
  // commands within timeout_s (it waits for the replies).
  bool stop(double now_s, double timeout_s) override;
  // Asks where the head is, unless an inquiry is already out and not yet timed out.
  void inquire(double now_s, double timeout_s) override;
  // Reads every waiting reply.
  void receive(double now_s) override;

  // The last measured pose and the time it was measured (mid round trip); nullopt before.
  std::optional<PtzPose> measured() const override { return core_.measured(); }
  double measuredAtS() const override { return core_.measuredAtS(); }
  int fd() const override { return socket_.fd(); }
  const ViscaModel& model() const { return core_.model(); }

  HeadStats& stats() override { return core_.stats(); }

 private:
  using Request = ViscaHeadCore::Request;
  ViscaHeadCore::Send sender(double now_s);

  ViscaHeadCore core_;
  UdpSocket socket_;
  uint32_t sequence_ = 0;
  struct Pending {
    Request what;
    double sent_s;
    bool acked;  // a command the camera took; its completion (or error) may take a while
  };
  std::map<uint32_t, Pending> outstanding_;  // by sequence number
};

}  // namespace ptz::driver
