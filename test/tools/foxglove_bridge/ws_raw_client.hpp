// A raw WebSocket client of the Foxglove server (handshake, text frames out, frames in) and the
// helpers its tests share: the server on 127.0.0.1, a subscribe op, waiting on its counters.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <string>
#include <thread>

#include "tools/foxglove_bridge/server.hpp"

namespace ptz::foxglove_bridge::test {

using namespace std::chrono_literals;

// A minimal WebSocket client on a blocking socket: handshake, masked text frames out, frames in.
class RawClient {
 public:
  RawClient(uint16_t port, int receive_buffer_bytes = 0) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (receive_buffer_bytes > 0) {
      setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receive_buffer_bytes, sizeof receive_buffer_bytes);
    }
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    const std::string hello =
        "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
        "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n";
    ok_ = ok_ && writeAll(hello);
    std::string response;
    char c = 0;
    while (ok_ && response.find("\r\n\r\n") == std::string::npos && readAll(&c, 1)) response += c;
    ok_ = ok_ && response.rfind("HTTP/1.1 101", 0) == 0;
  }
  ~RawClient() { ::close(fd_); }
  bool ok() const { return ok_; }

  bool sendText(const std::string& text) {
    std::string f(1, static_cast<char>(0x81));
    if (text.size() < 126) {
      f += static_cast<char>(0x80 | text.size());
    } else {
      f += static_cast<char>(0x80 | 126);
      f += static_cast<char>(text.size() >> 8);
      f += static_cast<char>(text.size() & 0xff);
    }
    f += std::string(4, '\0');  // a zero mask: the payload as it is
    return writeAll(f + text);
  }

  // The next frame's opcode and payload; false on timeout or a closed socket.
  bool readFrame(int* opcode, std::string* payload, std::chrono::milliseconds timeout = 10s) {
    deadline_ = std::chrono::steady_clock::now() + timeout;
    unsigned char h[2];
    if (!readAll(h, 2)) return false;
    *opcode = h[0] & 0x0f;
    uint64_t n = h[1] & 0x7f;
    if (n == 126 || n == 127) {
      unsigned char ext[8];
      const int k = n == 126 ? 2 : 8;
      if (!readAll(ext, k)) return false;
      n = 0;
      for (int i = 0; i < k; ++i) n = (n << 8) | ext[i];
    }
    payload->assign(n, '\0');
    return readAll(payload->data(), n);
  }
  // The next text frame (binary ones before it skipped).
  std::string readText() {
    int op = 0;
    std::string p;
    while (readFrame(&op, &p)) {
      if (op == 1) return p;
    }
    return "";
  }
  // The sequence number (the payload's first word) of the next binary frame.
  long readIndex() {
    int op = 0;
    std::string p;
    while (readFrame(&op, &p)) {
      if (op == 2) return std::stol(p.substr(kMessageDataHeaderBytes));
    }
    return -1;
  }

 private:
  bool writeAll(const std::string& s) {
    size_t done = 0;
    while (done < s.size()) {
      const ssize_t n = ::send(fd_, s.data() + done, s.size() - done, MSG_NOSIGNAL);
      if (n <= 0) return false;
      done += static_cast<size_t>(n);
    }
    return true;
  }
  bool readAll(void* out, size_t size) {
    auto* p = static_cast<char*>(out);
    while (size > 0) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline_ - std::chrono::steady_clock::now());
      pollfd pfd{fd_, POLLIN, 0};
      if (left.count() <= 0 || ::poll(&pfd, 1, static_cast<int>(left.count())) <= 0) return false;
      const ssize_t n = ::recv(fd_, p, size, 0);
      if (n <= 0) return false;
      p += n;
      size -= static_cast<size_t>(n);
    }
    return true;
  }

  int fd_ = -1;
  bool ok_ = false;
  std::chrono::steady_clock::time_point deadline_ = std::chrono::steady_clock::now() + 10s;
};

// Polls the server's counters (they are updated on its thread) until cond holds or 10 s passed.
template <class Cond>
bool waitFor(const Server& s, Cond cond) {
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (!cond(s.stats())) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::yield();
  }
  return true;
}

// On 127.0.0.1, a free port.
inline ServerOptions loopback() {
  ServerOptions o;
  o.address = "127.0.0.1";
  o.port = 0;
  return o;
}

inline std::string subscribe(uint32_t id, uint32_t channel) {
  return R"({"op":"subscribe","subscriptions":[{"id":)" + std::to_string(id) + R"(,"channelId":)" +
         std::to_string(channel) + "}]}";
}

}  // namespace ptz::foxglove_bridge::test
