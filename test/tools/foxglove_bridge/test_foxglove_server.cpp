// The Foxglove WebSocket server of ptz-foxglove-bridge on a real socket (127.0.0.1, a free
// port), with raw WebSocket clients written here: a client that never reads is held back (the
// publisher never waits, its messages replaced and counted) while a reading client gets every
// newest message; once the slow one reads, it gets the newest. A second subscription id for a
// channel and garbage are answered with statuses; stop() closes with clients connected.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <string>
#include <thread>

#include "tools/foxglove_bridge/server.hpp"

using namespace ptz::foxglove_bridge;
using namespace std::chrono_literals;

namespace {

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
ServerOptions loopback() {
  ServerOptions o;
  o.address = "127.0.0.1";
  o.port = 0;
  return o;
}

std::string subscribe(uint32_t id, uint32_t channel) {
  return R"({"op":"subscribe","subscriptions":[{"id":)" + std::to_string(id) + R"(,"channelId":)" +
         std::to_string(channel) + "}]}";
}

}  // namespace

TEST(FoxgloveServer, ASlowClientIsHeldBackWhileAReadingClientGetsEveryNewestMessage) {
  ServerOptions o = loopback();
  o.send_buffer_limit_bytes = 256 * 1024;
  Server server(o);
  const uint32_t channel = server.addChannel("/big", "json", "test.Big", "{}");
  server.start();
  ASSERT_GT(server.port(), 0);

  RawClient slow(server.port(), 4096), good(server.port());
  ASSERT_TRUE(slow.ok() && good.ok());
  for (RawClient* c : {&slow, &good}) {
    EXPECT_NE(c->readText().find(R"("op":"serverInfo")"), std::string::npos);
    EXPECT_NE(c->readText().find(R"("topic":"/big")"), std::string::npos);
  }
  ASSERT_TRUE(slow.sendText(subscribe(1, channel)));
  ASSERT_TRUE(good.sendText(subscribe(9, channel)));
  ASSERT_TRUE(waitFor(server, [](const ServerStats& s) { return s.subscriptions == 2; }));

  // 200 messages of 256 kB (50 MB): the slow client reads none of them.
  constexpr int kMessages = 200;
  const std::string pad(256 * 1024, 'x');
  for (int i = 0; i < kMessages; ++i) {
    server.publish(channel, static_cast<uint64_t>(i), std::to_string(i) + " " + pad);
    long got = -1;
    while (got < i) {
      got = good.readIndex();
      ASSERT_GE(got, 0) << "the reading client got nothing after message " << i;
    }
    ASSERT_EQ(got, i);  // never an older one after a newer
  }
  const ServerStats s = server.stats();
  EXPECT_GT(s.slow_client_waits, 0);
  EXPECT_GT(s.messages_dropped_slow_client, 0);
  // The slow client got at most its socket buffers and the limit's worth: far from all 200.
  EXPECT_LT(s.messages_sent, kMessages + kMessages / 2);
  EXPECT_GE(s.messages_sent, kMessages);

  // Once it reads, it gets the newest (the retry timer sends it).
  long last = -1;
  while (last != kMessages - 1) {
    const long got = slow.readIndex();
    ASSERT_GE(got, 0) << "the slow client never got the newest message (last " << last << ")";
    ASSERT_GT(got, last);
    last = got;
  }
  EXPECT_EQ(server.stats().clients, 2);
  server.stop();  // with both connected
  int op = 0;
  std::string payload;
  while (good.readFrame(&op, &payload) && op != 8) {
  }
  EXPECT_EQ(op, 8);  // close
  ASSERT_GE(payload.size(), 2u);
  EXPECT_EQ((static_cast<unsigned char>(payload[0]) << 8) | static_cast<unsigned char>(payload[1]),
            1001);  // going away
}

TEST(FoxgloveServer, ChannelsAddedLaterAreAdvertisedAndProblemsAnswered) {
  Server server(loopback());
  server.start();
  RawClient c(server.port());
  ASSERT_TRUE(c.ok());
  EXPECT_NE(c.readText().find("serverInfo"), std::string::npos);
  const uint32_t a = server.addChannel("/a", "json", "test.A", "{}");
  EXPECT_NE(c.readText().find(R"("topic":"/a")"), std::string::npos);
  ASSERT_TRUE(c.sendText(subscribe(1, a)));
  ASSERT_TRUE(c.sendText(subscribe(2, a)));
  EXPECT_EQ(c.readText(),
            R"({"op":"status","level":1,"message":"subscribe: subscriptions[0].channelId = 1: )"
            R"(already subscribed as subscription 1"})");
  ASSERT_TRUE(c.sendText("}{"));
  EXPECT_EQ(c.readText(), R"j({"op":"status","level":2,"message":"not JSON (2 bytes)"})j");
  server.publish(a, 0x0102030405060708ull, "{}");
  int op = 0;
  std::string frame;
  ASSERT_TRUE(c.readFrame(&op, &frame));
  EXPECT_EQ(op, 2);
  EXPECT_EQ(frame, messageDataFrame(1, 0x0102030405060708ull, "{}"));
  const ServerStats s = server.stats();
  EXPECT_EQ(s.client_errors, 2);
  EXPECT_EQ(s.client_errors_by_reason.at("already_subscribed"), 1);
  EXPECT_EQ(s.client_errors_by_reason.at("bad_json"), 1);
  EXPECT_EQ(s.statuses_sent, 2);
  EXPECT_EQ(s.messages_sent, 1);
}

TEST(FoxgloveServer, APortInUseIsNamed) {
  ServerOptions o = loopback();
  Server first(o);
  first.start();
  o.port = first.port();
  Server second(o);
  try {
    second.start();
    FAIL() << "listened twice on one port";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "cannot listen on 127.0.0.1:" + std::to_string(o.port) + ": Address already in use");
  }
}
