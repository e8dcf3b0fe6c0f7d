#include "sim/onvif/discovery_responder.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "ptz_driver/heads/onvif/ws_security.hpp"

namespace ptz::sim {
namespace {

std::runtime_error sysError(const std::string& what) {
  return std::runtime_error("WS-Discovery responder: " + what + ": " + std::strerror(errno));
}

constexpr int64_t kMaxWarnings = 10;  // on stderr; the counters say the rest

}  // namespace

DiscoveryResponder::DiscoveryResponder(std::vector<driver::DiscoveredCamera> cameras,
                                       const DiscoveryResponderOptions& options)
    : cameras_(std::move(cameras)), options_(options) {
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd_ < 0) throw sysError("socket");
  // Other responders (another ptz-sim, a real service) may share the port.
  const int one = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(options_.port));
  a.sin_addr.s_addr = htonl(INADDR_ANY);
  ip_mreq m{};
  const std::string where = options_.group + ":" + std::to_string(options_.port);
  if (::inet_pton(AF_INET, options_.group.c_str(), &m.imr_multiaddr) != 1) {
    ::close(fd_);
    throw std::runtime_error("WS-Discovery responder: group '" + options_.group + "' not IPv4");
  }
  m.imr_interface.s_addr = htonl(INADDR_ANY);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    const auto e = sysError("bind UDP port " + std::to_string(options_.port));
    ::close(fd_);
    throw e;
  }
  if (::setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof m) != 0) {
    const auto e = sysError("join " + where + " (no multicast route?)");
    ::close(fd_);
    throw e;
  }
  if (::pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) {
    const auto e = sysError("pipe");
    ::close(fd_);
    throw e;
  }
}

DiscoveryResponder::~DiscoveryResponder() {
  stop();
  ::close(fd_);
  ::close(wake_[0]);
  ::close(wake_[1]);
}

void DiscoveryResponder::start() {
  if (!thread_.joinable()) thread_ = std::thread([this] { serve(); });
}

void DiscoveryResponder::stop() {
  if (!thread_.joinable()) return;
  const char c = 0;
  [[maybe_unused]] const ssize_t n = ::write(wake_[1], &c, 1);
  thread_.join();
}

DiscoveryCounters DiscoveryResponder::counters() const {
  return {answered_, ignored_, oversize_, malformed_, send_errors_};
}

void DiscoveryResponder::serve() {
  // One byte more than allowed: a datagram that fills it is too large.
  std::string buf(options_.max_probe_bytes + 1, '\0');
  for (;;) {
    pollfd fds[2] = {{fd_, POLLIN, 0}, {wake_[0], POLLIN, 0}};
    if (::poll(fds, 2, -1) < 0 && errno != EINTR) {
      std::fprintf(stderr, "ptz-sim: WS-Discovery responder: poll: %s; stopped\n",
                   std::strerror(errno));
      return;
    }
    if (fds[1].revents) return;
    for (;;) {
      sockaddr_in from{};
      socklen_t from_len = sizeof from;
      const ssize_t n = ::recvfrom(fd_, buf.data(), buf.size(), MSG_TRUNC,
                                   reinterpret_cast<sockaddr*>(&from), &from_len);
      if (n < 0) break;  // EAGAIN: all read
      handle(buf.data(), static_cast<std::size_t>(n), &from, from_len);
    }
  }
}

void DiscoveryResponder::handle(const char* bytes, std::size_t n, const void* from,
                                unsigned from_len) {
  const auto* sender = static_cast<const sockaddr_in*>(from);
  char host[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &sender->sin_addr, host, sizeof host);
  const std::string who = std::string(host) + ":" + std::to_string(ntohs(sender->sin_port));
  auto warn = [&](const std::string& why) {
    if (warned_++ < kMaxWarnings) {
      std::fprintf(stderr, "ptz-sim: WS-Discovery: datagram from %s dropped: %s\n", who.c_str(),
                   why.c_str());
    }
  };
  if (n > options_.max_probe_bytes) {
    ++oversize_;
    warn(std::to_string(n) + " bytes, more than " + std::to_string(options_.max_probe_bytes));
    return;
  }
  const driver::ProbeRead probe = driver::readProbe(std::string_view(bytes, n));
  if (!probe.ok) {
    ++malformed_;
    warn(probe.error.substr(0, 200));
    return;
  }
  if (!probe.wants_camera) {
    ++ignored_;
    return;
  }
  ++answered_;
  for (const driver::DiscoveredCamera& c : cameras_) {
    // A fresh MessageID per answer (WS-Addressing), relating to the Probe's.
    const std::string reply =
        driver::probeMatchesMessage(c, probe.message_id, onvif::randomMessageId());
    if (::sendto(fd_, reply.data(), reply.size(), MSG_NOSIGNAL, static_cast<const sockaddr*>(from),
                 from_len) != static_cast<ssize_t>(reply.size())) {
      ++send_errors_;
      warn(std::string("answer not sent: ") + std::strerror(errno));
    }
  }
}

}  // namespace ptz::sim
