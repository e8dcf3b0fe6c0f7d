// ptz-sim's ONVIF HTTP server on 127.0.0.1 (free ports) with raw socket clients. The test pumps
// the server itself (serve() between the clients' writes), with its own clock, so requests are
// split for certain and the late GetStatus and the idle timeout need no waiting on the wall clock.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include "ptz_driver/heads/onvif/xml.hpp"
#include "sim/onvif/onvif_server.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::sim::OnvifServer;
using ptz::sim::OnvifServerOptions;

namespace {

const std::string kGeneric = PTZ_SOURCE_DIR "/config/onvif/generic_ptz.yaml";
const std::string kCheap = PTZ_SOURCE_DIR "/config/onvif/cheap_ptz.yaml";
const std::array<PtzPose, 2> kHeads = {PtzPose{0, 0, 1}, PtzPose{0.5, 0, 1}};

std::string soap(const std::string& op, const std::string& ns, const std::string& inner = "") {
  return "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"><s:Body><" + op +
         " xmlns=\"" + ns + "\">" + inner + "</" + op + "></s:Body></s:Envelope>";
}
const std::string kGetStatus = soap("GetStatus", "http://www.onvif.org/ver20/ptz/wsdl",
                                    "<ProfileToken>profile_1</ProfileToken>");
const std::string kGetTime = soap("GetSystemDateAndTime", "http://www.onvif.org/ver10/device/wsdl");

std::string post(const std::string& path, const std::string& body,
                 const std::string& extra_headers = "") {
  return "POST " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/soap+xml\r\n" +
         extra_headers + "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
}

struct Response {
  int status = 0;
  std::string head, body;
  bool closed = false;  // the server closed the connection after it
};

// A client socket; the server is pumped while it waits (the test's own clock advances only
// where the test says).
class Client {
 public:
  explicit Client(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0);
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port));
    ::inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a);  // EINPROGRESS on loopback
  }
  ~Client() { ::close(fd_); }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Writes all of `bytes` (pumping the server while the socket is full).
  void send(const std::string& bytes, OnvifServer* server, double now_s) {
    size_t sent = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (sent < bytes.size() && std::chrono::steady_clock::now() < deadline) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n > 0) {
        sent += static_cast<size_t>(n);
      } else if (n < 0 && errno != EAGAIN && errno != EINPROGRESS && errno != ENOTCONN) {
        break;  // reset: the server closed on us
      }
      server->wait(5, now_s);
      server->serve(now_s, kHeads);
    }
  }
  // Reads what arrived without pumping the server.
  void drain() {
    char buf[65536];
    for (;;) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n > 0) {
        in_.append(buf, static_cast<size_t>(n));
        continue;
      }
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK)) closed_ = true;
      return;
    }
  }
  // A whole response if one is there (after drain()).
  std::optional<Response> take() {
    const size_t end = in_.find("\r\n\r\n");
    if (end == std::string::npos) return std::nullopt;
    Response r;
    r.head = in_.substr(0, end);
    r.status = std::stoi(r.head.substr(9, 3));
    const size_t cl = r.head.find("Content-Length: ");
    const size_t length = cl == std::string::npos ? 0 : std::stoul(r.head.substr(cl + 16));
    if (in_.size() < end + 4 + length) return std::nullopt;
    r.body = in_.substr(end + 4, length);
    in_.erase(0, end + 4 + length);
    r.closed = closed_;
    return r;
  }
  // Pumps the server at now_s until a whole response came (or 20 s of wall time).
  Response await(OnvifServer* server, double now_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
      server->serve(now_s, kHeads);
      drain();
      if (auto r = take()) {
        if (r->head.find("Connection: close") != std::string::npos) {
          // The close follows the bytes: wait for it too.
          while (!closed_ && std::chrono::steady_clock::now() < deadline) {
            server->wait(5, now_s);
            server->serve(now_s, kHeads);
            drain();
          }
          r->closed = closed_;
        }
        return *r;
      }
      if (closed_) return Response{0, "", "", true};
      server->wait(5, now_s);
    }
    return {};
  }
  bool closed() const { return closed_; }
  void shutdownWrite() { ::shutdown(fd_, SHUT_WR); }

 private:
  int fd_ = -1;
  std::string in_;
  bool closed_ = false;
};

OnvifServerOptions options() {
  OnvifServerOptions o;
  o.first_port = 0;  // free ports
  return o;
}

std::array<ptz::driver::OnvifCameraSettings, 2> settings() {
  std::array<ptz::driver::OnvifCameraSettings, 2> s;
  s[0].serial = "L";
  s[1].serial = "R";
  return s;
}

std::string panX(const Response& r) {
  const auto doc = ptz::onvif::XmlDocument::parse(r.body);
  const auto pt =
      doc.root().find({"Body", "GetStatusResponse", "PTZStatus", "Position", "PanTilt"});
  return pt.attribute("x").value_or("");
}

}  // namespace

TEST(OnvifServer, ARequestSplitOverManyWritesIsAnsweredAndTheConnectionKeptAlive) {
  OnvifServer server(ptz::driver::OnvifModel::load(kGeneric), settings(), options(), kHeads);
  Client c(server.port(Side::kLeft));
  const std::string request = post("/onvif/ptz_service", kGetStatus);
  // Byte by byte through the head, then the body in three pieces, the server served between.
  const size_t head = request.find("\r\n\r\n") + 4;
  for (size_t i = 0; i < head; ++i) c.send(request.substr(i, 1), &server, 100);
  const size_t third = (request.size() - head) / 3;
  c.send(request.substr(head, third), &server, 100);
  c.send(request.substr(head + third, third), &server, 100);
  EXPECT_FALSE(c.take());
  c.send(request.substr(head + 2 * third), &server, 100);
  const Response r = c.await(&server, 100);
  EXPECT_EQ(r.status, 200) << r.head << r.body;
  EXPECT_NE(r.head.find("Content-Type: application/soap+xml"), std::string::npos);
  EXPECT_EQ(panX(r), "0");
  // The same connection serves the next two requests, sent at once (pipelined), in order.
  c.send(post("/onvif/device_service", kGetTime) + post("/onvif/ptz_service", kGetStatus), &server,
         100);
  const Response second = c.await(&server, 100), third_r = c.await(&server, 100);
  EXPECT_EQ(second.status, 200);
  EXPECT_NE(second.body.find("GetSystemDateAndTimeResponse"), std::string::npos);
  // XAddrs name the host the client reached, with our port when its Host header had none.
  c.send(post("/onvif/device_service", soap("GetServices", "http://www.onvif.org/ver10/device/wsdl",
                                            "<IncludeCapability>false</IncludeCapability>")),
         &server, 100);
  const Response services = c.await(&server, 100);
  EXPECT_NE(services.body.find("<tds:XAddr>http://127.0.0.1:" +
                               std::to_string(server.port(Side::kLeft)) + "/onvif/ptz_service<"),
            std::string::npos)
      << services.body;
  EXPECT_EQ(third_r.status, 200);
  EXPECT_NE(third_r.body.find("GetStatusResponse"), std::string::npos);
  EXPECT_FALSE(c.closed());
  EXPECT_EQ(server.counters().requests, 4);  // and the half-closed client's below
  EXPECT_EQ(server.counters().bad_requests, 0);
  // A client that half-closes after its request still gets the answer.
  {
    Client h(server.port(Side::kRight));
    h.send(post("/onvif/ptz_service", kGetStatus), &server, 100);
    h.shutdownWrite();
    const Response half = h.await(&server, 100);
    EXPECT_EQ(half.status, 200);
    EXPECT_NE(half.body.find("GetStatusResponse"), std::string::npos);
  }
  // Expect: 100-continue gets its 100 before the body is sent.
  const std::string body = kGetStatus;
  c.send(
      "POST /onvif/ptz_service HTTP/1.1\r\nHost: 127.0.0.1\r\nExpect: 100-continue\r\n"
      "Content-Length: " +
          std::to_string(body.size()) + "\r\n\r\n",
      &server, 100);
  EXPECT_EQ(c.await(&server, 100).status, 100);
  c.send(body, &server, 100);
  EXPECT_EQ(c.await(&server, 100).status, 200);
  // Connection: close is honoured.
  c.send(post("/onvif/ptz_service", kGetStatus, "Connection: close\r\n"), &server, 100);
  const Response last = c.await(&server, 100);
  EXPECT_EQ(last.status, 200);
  EXPECT_TRUE(last.closed);
}

TEST(OnvifServer, TooLargeMalformedUnknownAndWrongMethodAreRefusedAndCounted) {
  OnvifServer server(ptz::driver::OnvifModel::load(kGeneric), settings(), options(), kHeads);
  const int port = server.port(Side::kRight);
  const auto one = [&](const std::string& bytes) {
    Client c(port);
    c.send(bytes, &server, 100);
    return c.await(&server, 100);
  };
  // A declared body beyond 64 KiB: 413 before a byte of it is read.
  Response r = one("POST /onvif/ptz_service HTTP/1.1\r\nContent-Length: 70000\r\n\r\n");
  EXPECT_EQ(r.status, 413);
  EXPECT_TRUE(r.closed);
  // The same with the body sent anyway: the 413 still reaches the client (the server lingers,
  // discarding, instead of resetting the connection).
  r = one("POST /onvif/ptz_service HTTP/1.1\r\nContent-Length: 70000\r\n\r\n" +
          std::string(70000, 'x'));
  EXPECT_EQ(r.status, 413);
  EXPECT_TRUE(r.closed);
  // A head that never ends, beyond the limit.
  r = one("POST /onvif/ptz_service HTTP/1.1\r\nX-Long: " + std::string(70000, 'a'));
  EXPECT_EQ(r.status, 413);
  EXPECT_EQ(one("GARBAGE\r\n\r\n").status, 400);
  EXPECT_EQ(one("POST /onvif/ptz_service HTTP/2.0\r\n\r\n").status, 400);
  EXPECT_EQ(one("POST /onvif/ptz_service HTTP/1.1\r\nContent-Length: 1x\r\n\r\n").status, 400);
  EXPECT_EQ(one("POST /onvif/ptz_service HTTP/1.1\r\nContent-Length: 5\r\nContent-Length: 6"
                "\r\n\r\n")
                .status,
            400);
  EXPECT_EQ(one("POST /onvif/ptz_service HTTP/1.1\r\nno colon here\r\n\r\n").status, 400);
  EXPECT_EQ(one("POST /onvif/ptz_service HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n").status,
            400);
  EXPECT_EQ(one(post("/index.html", kGetStatus)).status, 404);
  EXPECT_EQ(one("GET /onvif/ptz_service HTTP/1.1\r\nHost: x\r\n\r\n").status, 405);
  EXPECT_EQ(server.counters().bad_requests, 11);
  // A SOAP body that is not XML is the camera's to refuse: a fault, not an HTTP error.
  r = one(post("/onvif/ptz_service", "<not xml"));
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(r.body.find("ter:WellFormed"), std::string::npos);
  EXPECT_EQ(server.counters().soap_faults, 1);
  EXPECT_EQ(server.counters().bad_requests, 11);
  // After all that the server still answers.
  EXPECT_EQ(one(post("/onvif/ptz_service", kGetStatus)).status, 200);
}

TEST(OnvifServer, TwoClientsAtOnceOnBothCameras) {
  OnvifServer server(ptz::driver::OnvifModel::load(kGeneric), settings(), options(), kHeads);
  Client left(server.port(Side::kLeft)), right(server.port(Side::kRight));
  const std::string request = post("/onvif/ptz_service", kGetStatus);
  const size_t half = request.size() / 2;
  // Interleaved halves: neither waits for the other.
  left.send(request.substr(0, half), &server, 100);
  right.send(request.substr(0, half), &server, 100);
  right.send(request.substr(half), &server, 100);
  left.send(request.substr(half), &server, 100);
  const Response r = right.await(&server, 100), l = left.await(&server, 100);
  EXPECT_EQ(l.status, 200);
  EXPECT_EQ(r.status, 200);
  // Each camera its own head: the right one is panned.
  EXPECT_EQ(panX(l), "0");
  EXPECT_NE(panX(r), "0");
  EXPECT_EQ(server.connections(), 2u);
}

TEST(OnvifServer, ACheapCamerasLateStatusDoesNotHoldTheOtherCamera) {
  OnvifServer server(ptz::driver::OnvifModel::load(kCheap), settings(), options(), kHeads);
  Client slow(server.port(Side::kLeft)), quick(server.port(Side::kRight));
  const double t0_s = 1000;
  slow.send(post("/onvif/ptz_service", kGetStatus), &server, t0_s);
  server.serve(t0_s, kHeads);  // the late reply is scheduled now, for t0 + 0.3 s
  quick.send(post("/onvif/device_service", kGetTime), &server, t0_s + 0.01);
  const Response q = quick.await(&server, t0_s + 0.01);
  EXPECT_EQ(q.status, 200);
  slow.drain();
  EXPECT_FALSE(slow.take()) << "the late status came early";
  // Just before its time: still nothing; at its time: there.
  server.serve(t0_s + 0.29, kHeads);
  slow.drain();
  EXPECT_FALSE(slow.take());
  const Response s = slow.await(&server, t0_s + 0.3);
  EXPECT_EQ(s.status, 200);
  EXPECT_NE(s.body.find("GetStatusResponse"), std::string::npos);
  // A slow client's late reply does not block a second request of the quick one either.
  slow.send(post("/onvif/ptz_service", kGetStatus), &server, t0_s + 1);
  quick.send(post("/onvif/ptz_service", kGetStatus), &server, t0_s + 1);
  // The quick camera is cheap too (one model): both late; the quick one's due at the same time.
  const Response q2 = quick.await(&server, t0_s + 1.3);
  EXPECT_EQ(q2.status, 200);
  EXPECT_EQ(slow.await(&server, t0_s + 1.3).status, 200);
}

TEST(OnvifServer, ConnectionsBeyondTheCapAreRefusedAndSilentOnesClosed) {
  OnvifServerOptions o = options();
  o.max_connections = 2;
  o.idle_timeout_s = 5;
  OnvifServer server(ptz::driver::OnvifModel::load(kGeneric), settings(), o, kHeads);
  const int port = server.port(Side::kLeft);
  Client a(port), b(port);
  a.send("POST /onvif/ptz_service HTTP/1.1\r\n", &server, 100);  // half a head, then silence
  b.send("POST", &server, 100);
  ASSERT_EQ(server.connections(), 2u);
  Client c(port);
  const Response refused = c.await(&server, 100);
  EXPECT_EQ(refused.status, 503);
  EXPECT_EQ(server.counters().connections_refused, 1);
  // The silent ones are closed after the idle timeout, and a new client is served.
  server.serve(106, kHeads);
  EXPECT_EQ(server.connections(), 0u);
  EXPECT_EQ(server.counters().connections_timed_out, 2);
  a.drain();
  EXPECT_TRUE(a.closed());
  {
    Client d(port);
    d.send(post("/onvif/ptz_service", kGetStatus), &server, 106);
    EXPECT_EQ(d.await(&server, 106).status, 200);
  }
  server.serve(107, kHeads);  // d's close seen
  // A client trickling its request a byte every 2 s is never silent for 5 s, but its request
  // is unfinished for more: closed.
  Client slowloris(port);
  const std::string request = post("/onvif/ptz_service", kGetStatus);
  for (int i = 0; i < 3; ++i) slowloris.send(request.substr(i, 1), &server, 200 + 2 * i);
  EXPECT_EQ(server.counters().connections_timed_out, 2);
  slowloris.send(request.substr(3, 1), &server, 206);
  server.serve(206, kHeads);
  EXPECT_EQ(server.counters().connections_timed_out, 3);
  slowloris.drain();
  EXPECT_TRUE(slowloris.closed());
}

TEST(OnvifServer, PasswordFromTheFileOrTheEnvironment) {
  const std::string file = "/tmp/ptz_onvif_pw_" + std::to_string(getpid());
  {
    std::FILE* f = std::fopen(file.c_str(), "w");
    std::fputs("from file\r\nsecond line\n", f);
    std::fclose(f);
  }
  EXPECT_EQ(ptz::sim::onvifPassword(file), "from file");
  ::unlink(file.c_str());
  EXPECT_THROW(ptz::sim::onvifPassword(file), std::exception);
  ::setenv("PTZ_SIM_ONVIF_PASSWORD", "from env", 1);
  EXPECT_EQ(ptz::sim::onvifPassword(""), "from env");
  ::unsetenv("PTZ_SIM_ONVIF_PASSWORD");
  EXPECT_EQ(ptz::sim::onvifPassword(""), "");
}
