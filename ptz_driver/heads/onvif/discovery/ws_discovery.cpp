#include "ptz_driver/heads/onvif/discovery/ws_discovery.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <set>

#include "ptz_driver/heads/onvif/requests.hpp"

namespace ptz::onvif {
namespace {

constexpr std::size_t kMaxProblems = 8;

class Socket {
 public:
  Socket() : fd_(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0)) {}
  ~Socket() {
    if (fd_ >= 0) ::close(fd_);
  }
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;
  int fd() const { return fd_; }

 private:
  int fd_;
};

Error sysError(const std::string& what) {
  return Error{"WS-Discovery: " + what + ": " + std::strerror(errno), std::nullopt};
}

int64_t nowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::string percentDecoded(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      const char c = static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      // A decoded control character would reach the terminal: kept encoded.
      if (static_cast<unsigned char>(c) >= 0x20 && c != 0x7f) {
        out += c;
        i += 2;
        continue;
      }
    }
    out += s[i];
  }
  return out;
}

}  // namespace

std::string scopeValue(const std::vector<std::string>& scopes, const std::string& kind) {
  const std::string prefix = "onvif://www.onvif.org/" + kind + "/";
  for (const std::string& s : scopes) {
    if (s.rfind(prefix, 0) == 0) return percentDecoded(s.substr(prefix.size()));
  }
  return "";
}

Result<DiscoveryResult> discover(const DiscoveryOptions& options) {
  Socket sock;
  if (sock.fd() < 0) return sysError("socket");
  sockaddr_in any{};
  any.sin_family = AF_INET;
  any.sin_addr.s_addr = htonl(INADDR_ANY);
  if (::bind(sock.fd(), reinterpret_cast<const sockaddr*>(&any), sizeof any) != 0) {
    return sysError("bind");
  }
  const int ttl = options.ttl;
  if (::setsockopt(sock.fd(), IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl) != 0) {
    return sysError("multicast TTL " + std::to_string(ttl));
  }
  if (!options.interface_address.empty()) {
    in_addr a{};
    if (::inet_pton(AF_INET, options.interface_address.c_str(), &a) != 1) {
      return Error{"WS-Discovery: interface address '" + options.interface_address +
                       "' is not an IPv4 address",
                   std::nullopt};
    }
    if (::setsockopt(sock.fd(), IPPROTO_IP, IP_MULTICAST_IF, &a, sizeof a) != 0) {
      return sysError("interface " + options.interface_address);
    }
  }
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(options.port));
  if (::inet_pton(AF_INET, options.group.c_str(), &to.sin_addr) != 1) {
    return Error{"WS-Discovery: address '" + options.group + "' is not IPv4", std::nullopt};
  }

  DiscoveryResult result;
  result.message_id = randomMessageId();
  const std::string probe = probeMessage(result.message_id);
  const std::string where = options.group + ":" + std::to_string(options.port);
  if (::sendto(sock.fd(), probe.data(), probe.size(), 0, reinterpret_cast<const sockaddr*>(&to),
               sizeof to) != static_cast<ssize_t>(probe.size())) {
    return sysError("Probe to " + where + " not sent (no route to the group?)");
  }

  auto drop = [&](int64_t* counter, const std::string& from, const std::string& why) {
    ++*counter;
    if (result.problems.size() < kMaxProblems) result.problems.push_back(from + ": " + why);
  };
  std::set<std::string> seen;
  // One byte more than allowed: a datagram that fills it is too large (MSG_TRUNC says by how much).
  std::string buf(options.max_reply_bytes + 1, '\0');
  const int64_t deadline_ms = nowMs() + options.timeout_ms;
  for (;;) {
    const int64_t left_ms = deadline_ms - nowMs();
    if (left_ms <= 0) break;
    pollfd p{sock.fd(), POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(left_ms));
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) return sysError("poll");
    if (ready == 0) break;
    sockaddr_in from{};
    socklen_t from_len = sizeof from;
    const ssize_t n = ::recvfrom(sock.fd(), buf.data(), buf.size(), MSG_TRUNC,
                                 reinterpret_cast<sockaddr*>(&from), &from_len);
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      return sysError("receive");
    }
    ++result.counters.replies;
    char host[INET_ADDRSTRLEN] = "?";
    ::inet_ntop(AF_INET, &from.sin_addr, host, sizeof host);
    const std::string sender = std::string(host) + ":" + std::to_string(ntohs(from.sin_port));
    if (static_cast<std::size_t>(n) > options.max_reply_bytes) {
      drop(&result.counters.oversize, sender,
           std::to_string(n) + " bytes, more than " + std::to_string(options.max_reply_bytes));
    } else {
      const auto matches = parseProbeMatches(std::string_view(buf.data(), n), result.message_id);
      if (!matches) {
        // parseProbeMatches names the field first: RelatesTo is the other Probe's answer.
        const bool other = matches.error().rfind("Header/RelatesTo", 0) == 0;
        drop(other ? &result.counters.wrong_relates_to : &result.counters.malformed, sender,
             matches.error().substr(0, 200));
      } else {
        for (const ProbeMatch& m : *matches) {
          ++result.counters.matches;
          if (!seen.insert(m.endpoint).second) {
            ++result.counters.duplicates;
          } else if (result.devices.size() >= options.max_devices) {
            drop(&result.counters.beyond_limits, sender, "more than max_devices endpoints");
          } else {
            result.devices.push_back(m);
          }
        }
      }
    }
    if (static_cast<std::size_t>(result.counters.replies) >= options.max_replies) {
      drop(&result.counters.beyond_limits, sender,
           "max_replies datagrams read: the rest not waited for");
      break;
    }
  }
  return result;
}

}  // namespace ptz::onvif
