// A UDP socket on IPv4 (VISCA over IP): bound to a local port, or connected to a camera.
#pragma once

#include <cstdint>
#include <string>

#include "ptz_driver/io/bytes.hpp"

namespace ptz::driver {

class UdpSocket {
 public:
  UdpSocket() = default;
  ~UdpSocket();
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;

  // Throws std::runtime_error naming the address.
  void bind(const std::string& host, int port);
  void connect(const std::string& host, int port);
  bool send(const Bytes& data);
  // Replies to whoever sent the last datagram received (a bound socket's peer).
  bool sendToLastPeer(const Bytes& data);
  // One datagram if one is waiting (non-blocking); false when none.
  bool receive(Bytes* data);
  int fd() const { return fd_; }

 private:
  void open();
  int fd_ = -1;
  uint8_t peer_[16] = {};  // sockaddr_in of the last sender
  bool has_peer_ = false;
};

}  // namespace ptz::driver
