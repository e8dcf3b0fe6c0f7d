// ptz-sim's ONVIF cameras answer WS-Discovery: a UDP socket on 3702 in the group 239.255.255.250
// (any interface the group routes to), a Probe for cameras answered by one ProbeMatches per camera,
// unicast to the prober. Every datagram is outside bytes: larger than max_probe_bytes is dropped
// unread, the rest read with libxml2's limits (onvif_discovery.hpp); drops are counted, never
// fatal. A thread of its own, woken to stop through a pipe.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "ptz_driver/emulators/onvif/onvif_discovery.hpp"

namespace ptz::sim {

struct DiscoveryResponderOptions {
  std::string group = "239.255.255.250";
  int port = 3702;
  std::size_t max_probe_bytes = 16 * 1024;  // a Probe is about 1 kB
};

struct DiscoveryCounters {
  int64_t answered = 0;     // Probes answered (one ProbeMatches per camera each)
  int64_t ignored = 0;      // Probes for other device types
  int64_t oversize = 0;     // dropped unread
  int64_t malformed = 0;    // not a Probe that reads
  int64_t send_errors = 0;  // an answer that could not be sent
};

class DiscoveryResponder {
 public:
  // Throws std::runtime_error naming the socket step that failed (no multicast route, say).
  DiscoveryResponder(std::vector<driver::DiscoveredCamera> cameras,
                     const DiscoveryResponderOptions& options = {});
  ~DiscoveryResponder();
  DiscoveryResponder(const DiscoveryResponder&) = delete;
  DiscoveryResponder& operator=(const DiscoveryResponder&) = delete;

  void start();
  void stop();
  DiscoveryCounters counters() const;

 private:
  void serve();
  void handle(const char* bytes, std::size_t n, const void* from, unsigned from_len);

  std::vector<driver::DiscoveredCamera> cameras_;
  DiscoveryResponderOptions options_;
  int fd_ = -1;
  int wake_[2] = {-1, -1};
  std::thread thread_;
  std::atomic<int64_t> answered_{0}, ignored_{0}, oversize_{0}, malformed_{0}, send_errors_{0};
  std::atomic<int64_t> warned_{0};
};

}  // namespace ptz::sim
