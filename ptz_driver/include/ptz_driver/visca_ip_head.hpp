// One PTZ camera over VISCA over IP: absolute pan-tilt and zoom commands, position inquiries,
// replies matched to requests by sequence number, round-trip times, errors by name. Inquiries
// not answered within the timeout are sent again; a "command buffer full" error makes the next
// command wait for the buffer to drain (a reply) instead of piling on.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ptz_driver/head.hpp"
#include "ptz_driver/udp.hpp"
#include "ptz_driver/visca_camera.hpp"

namespace ptz::driver {

class ViscaIpHead : public PtzHead {
 public:
  // Connects to host:port; throws std::runtime_error naming it when the address is bad.
  ViscaIpHead(ViscaModel model, const std::string& host, int port, int address = 1);

  // Resets the camera's sequence number (Sony's RESET control command).
  void start(double now_s) override;
  // Moves to pose (clamped to the model's range); only sends what changed by a unit or more.
  void command(const PtzPose& pose, double now_s) override;
  // Stops pan, tilt and zoom where they are. Returns whether the camera acknowledged (or
  // completed, or refused) both commands within timeout_s (it waits for the replies).
  bool stop(double now_s, double timeout_s) override;
  // Asks where the head is, unless an inquiry is already out and not yet timed out.
  void inquire(double now_s, double timeout_s) override;
  // Reads every waiting reply.
  void receive(double now_s) override;

  // The last measured pose and the time it was measured (mid round trip); nullopt before.
  std::optional<PtzPose> measured() const override;
  double measuredAtS() const override { return measured_at_s_; }
  int fd() const override { return socket_.fd(); }
  const ViscaModel& model() const { return model_; }

  HeadStats& stats() override { return stats_; }

 private:
  enum class Request { kPanTiltInquiry, kZoomInquiry, kCommand, kReset };
  bool send(uint16_t type, const Bytes& payload, Request what, double now_s);

  ViscaModel model_;
  int address_;
  UdpSocket socket_;
  uint32_t sequence_ = 0;
  struct Pending {
    Request what;
    double sent_s;
    bool acked;  // a command the camera took; its completion (or error) may take a while
  };
  std::map<uint32_t, Pending> outstanding_;  // by sequence number
  std::optional<int32_t> pan_units_, tilt_units_;
  std::optional<int> zoom_position_;
  double measured_at_s_ = 0;
  double inquiry_sent_s_ = -1;
  std::optional<int32_t> sent_pan_, sent_tilt_;
  std::optional<int> sent_zoom_;
  bool buffer_full_ = false;
  HeadStats stats_;
};

}  // namespace ptz::driver
