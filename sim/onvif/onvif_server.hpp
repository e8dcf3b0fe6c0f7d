// ptz-sim's heads as ONVIF cameras over HTTP/1.1 (left at port, right at port + 1): a minimal
// server on non-blocking sockets, one poll loop, that routes POST /onvif/{device,media,ptz}_service
// to the ONVIF camera emulators; their moves become setpoints of the PT1 + dead-time plant, and
// GetStatus reads the plant. Request size, connection count and idle time are capped, so no
// client (slow, hostile, or many) holds the loop or the other camera; a cheap camera's late
// GetStatus is scheduled, never slept on.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <functional>

#include "common/rig.hpp"
#include "ptz_driver/emulators/onvif/http_digest.hpp"
#include "ptz_driver/emulators/onvif/onvif_camera_emulator.hpp"
#include "sim/onvif/discovery_responder.hpp"

namespace ptz::sim {

struct OnvifServerOptions {
  std::string host = "127.0.0.1";
  int first_port = 0;                    // 0: any free ports (tests)
  size_t max_request_bytes = 64 * 1024;  // head and body; 413 beyond
  size_t max_connections = 32;           // both cameras; 503 and closed beyond
  double idle_timeout_s = 10;            // a connection silent (or a request unfinished) this long
  bool discovery = false;                // OnvifCameras: answer WS-Discovery probes
  // HTTP digest (MD5) demanded of every request besides WS-UsernameToken, with the cameras'
  // user and password: 401 and the challenge without it.
  bool http_digest = false;
  DiscoveryResponderOptions discovery_options;
};

struct OnvifServerCounters {
  int64_t requests = 0;             // HTTP requests answered (200 or a SOAP fault)
  int64_t bad_requests = 0;         // 400, 404, 405, 413: not a request the cameras could read
  int64_t soap_faults = 0;          // SOAP faults the cameras answered (auth refusals included)
  int64_t auth_refused = 0;         // ter:NotAuthorized, and 401s (HTTP digest) after the first
  int64_t digest_challenges = 0;    // 401s answering a request without Authorization
  int64_t connections_refused = 0;  // beyond max_connections
  int64_t connections_timed_out = 0;
};

class OnvifServer {
 public:
  OnvifServer(const driver::OnvifModel& model,
              const std::array<driver::OnvifCameraSettings, 2>& cameras,
              const OnvifServerOptions& options, const std::array<PtzPose, 2>& home);
  ~OnvifServer();
  OnvifServer(const OnvifServer&) = delete;
  OnvifServer& operator=(const OnvifServer&) = delete;

  int port(Side side) const { return ports_[static_cast<size_t>(side)]; }
  // Waits up to timeout_ms for a socket to be ready or a scheduled reply to fall due.
  void wait(int timeout_ms, double host_now_s) const;
  // Accepts, reads, answers, writes and sends the replies due, with the heads at `now` and the
  // host clock (Unix s) at host_now_s.
  void serve(double host_now_s, const std::array<PtzPose, 2>& now);
  // Where the cameras' moves put the plant's setpoint at host_now_s.
  PtzPose setpoint(Side side, double host_now_s) const;
  OnvifServerCounters counters() const;
  size_t connections() const { return connections_.size(); }

 private:
  struct Connection {
    int fd = -1;
    size_t camera = 0;
    std::string in, out;
    double last_activity_s = 0;
    double request_start_s = 0;  // when the first byte of what is in `in` came
    bool continue_sent = false;  // 100 Continue sent for the request in `in`
    bool close_after_write = false;
    double closing_since_s = -1;  // answered and shut down for writing: lingering
    // A cheap camera's late reply: nothing more is read from this connection until it went
    // out (HTTP/1.1 answers in order).
    std::string delayed;
    double delayed_due_s = -1;
  };
  void accept(size_t camera, double host_now_s);
  // Handles every complete request in c.in; false when the connection is to be closed now.
  bool handleInput(Connection* c, double host_now_s, const PtzPose& now);
  void respond(Connection* c, int status, const std::string& body, bool close,
               const std::string& extra_headers = "");
  static bool flush(Connection* c);  // false on a write error

  std::array<int, 2> listen_fds_{-1, -1};
  std::array<int, 2> ports_{0, 0};
  std::vector<driver::OnvifCameraEmulator> cameras_;
  std::array<driver::DigestCredentials, 2> digest_;  // http_digest: each camera's
  int64_t digest_refused_ = 0;
  OnvifServerOptions options_;
  std::vector<std::unique_ptr<Connection>> connections_;
  OnvifServerCounters counters_;
};

// The server on a thread of its own, as sim's ViscaCameras: every poll with the motors at that
// moment; the cameras' setpoints handed to the plant when they change (continuous moves and
// speed ramps change them every loop). Knows nothing of the simulator: `motors` runs a step
// with the motors locked (SimRun::withMotorsNow in ptz-sim).
class OnvifCameras {
 public:
  // The heads now -> the setpoints to command, or nothing.
  using Step = std::function<std::optional<std::array<PtzPose, 2>>(const std::array<PtzPose, 2>&)>;
  using Motors = std::function<void(const Step&)>;

  OnvifCameras(const driver::OnvifModel& model,
               const std::array<driver::OnvifCameraSettings, 2>& cameras,
               const OnvifServerOptions& options, Motors motors);
  ~OnvifCameras() { stop(); }
  void start();
  void stop();
  OnvifServerCounters counters() const;
  int64_t setpointsApplied() const { return setpoints_applied_; }
  int port(Side side) const { return server_->port(side); }
  // Zero when discovery is off (or could not start: stderr said why).
  DiscoveryCounters discoveryCounters() const;

 private:
  void serve();

  std::unique_ptr<OnvifServer> server_;
  std::unique_ptr<DiscoveryResponder> discovery_;
  Motors motors_;
  std::array<PtzPose, 2> applied_{};
  std::thread thread_;
  std::atomic<bool> quit_{false};
  mutable std::mutex counters_mutex_;
  OnvifServerCounters counters_;
  std::atomic<int64_t> setpoints_applied_{0};
};

// The password of the ONVIF cameras: the first line of `file`, else the environment variable
// PTZ_SIM_ONVIF_PASSWORD, else "" (no authentication). Never a flag's value (ps shows those).
std::string onvifPassword(const std::string& file);

}  // namespace ptz::sim
