#include "ptz_driver/io/udp.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace ptz::driver {
namespace {
sockaddr_in address(const std::string& host, int port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  if (inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1) {
    throw std::runtime_error("'" + host + "' is not an IPv4 address");
  }
  return a;
}
}  // namespace

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) ::close(fd_);
}

void UdpSocket::open() {
  if (fd_ >= 0) return;
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0)
    throw std::runtime_error(std::string("cannot open a UDP socket: ") + strerror(errno));
}

void UdpSocket::bind(const std::string& host, int port) {
  open();
  const sockaddr_in a = address(host, port);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0) {
    throw std::runtime_error("cannot bind UDP " + host + ":" + std::to_string(port) + ": " +
                             strerror(errno));
  }
}

void UdpSocket::connect(const std::string& host, int port) {
  open();
  const sockaddr_in a = address(host, port);
  if (::connect(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0) {
    throw std::runtime_error("cannot reach UDP " + host + ":" + std::to_string(port) + ": " +
                             strerror(errno));
  }
}

bool UdpSocket::send(const Bytes& data) {
  return ::send(fd_, data.data(), data.size(), 0) == static_cast<ssize_t>(data.size());
}

bool UdpSocket::sendToLastPeer(const Bytes& data) {
  if (!has_peer_) return false;
  return ::sendto(fd_, data.data(), data.size(), 0, reinterpret_cast<const sockaddr*>(peer_),
                  sizeof(sockaddr_in)) == static_cast<ssize_t>(data.size());
}

bool UdpSocket::receive(Bytes* data) {
  uint8_t buffer[2048];
  sockaddr_in from{};
  socklen_t from_len = sizeof(from);
  const ssize_t n =
      ::recvfrom(fd_, buffer, sizeof(buffer), 0, reinterpret_cast<sockaddr*>(&from), &from_len);
  if (n < 0) return false;
  static_assert(sizeof(peer_) >= sizeof(sockaddr_in));
  std::memcpy(peer_, &from, sizeof(from));
  has_peer_ = true;
  data->assign(buffer, buffer + n);
  return true;
}

}  // namespace ptz::driver
