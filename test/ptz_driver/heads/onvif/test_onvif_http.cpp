// ptz_onvif's HTTP client against a real TCP server in the test (a thread on 127.0.0.1, port 0):
// the request as it arrives, 200 and 500 replies, a reply over the limit, a server that never
// answers (the timeout), a connection closed without a reply, nobody listening.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <future>
#include <string>
#include <thread>

#include "ptz_driver/heads/onvif/http.hpp"
#include "ptz_driver/heads/onvif/requests.hpp"

namespace ptz::onvif {
namespace {

// One connection: reads one request (headers and Content-Length body), then answers as `mode`
// says. Every wait is bounded (10 s), so a broken client cannot hang the test.
class TestServer {
 public:
  enum class Mode { kAnswer, kNeverAnswer, kClose };

  TestServer(Mode mode, std::string answer) {
    listener_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof a;
    if (listener_ < 0 || bind(listener_, reinterpret_cast<sockaddr*>(&a), size) != 0 ||
        listen(listener_, 1) != 0 ||
        getsockname(listener_, reinterpret_cast<sockaddr*>(&a), &size) != 0) {
      ADD_FAILURE() << "cannot listen on 127.0.0.1";
    }
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this, mode, answer = std::move(answer)] { serve(mode, answer); });
  }
  ~TestServer() {
    thread_.join();
    close(listener_);
  }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_) + "/onvif/ptz"; }
  // The request as received (waits for it, at most 10 s).
  std::string request() {
    if (received_.wait_for(std::chrono::seconds(10)) != std::future_status::ready) return "";
    return received_.get();
  }

 private:
  static bool readable(int fd) {
    pollfd p{fd, POLLIN, 0};
    return poll(&p, 1, 10000) == 1;
  }

  void serve(Mode mode, const std::string& answer) {
    std::string request;
    int fd = -1;
    if (readable(listener_)) fd = accept(listener_, nullptr, nullptr);
    if (fd >= 0) {
      char buffer[4096];
      std::size_t want = std::string::npos;
      while (request.size() < want && readable(fd)) {
        const ssize_t n = recv(fd, buffer, sizeof buffer, 0);
        if (n <= 0) break;
        request.append(buffer, static_cast<std::size_t>(n));
        const auto end = request.find("\r\n\r\n");
        const auto length = request.find("Content-Length: ");
        if (end != std::string::npos && length != std::string::npos && length < end) {
          want = end + 4 + std::strtoul(request.c_str() + length + 16, nullptr, 10);
        }
      }
    }
    promise_.set_value(request);
    if (fd < 0) return;
    if (mode == Mode::kAnswer) {
      std::size_t sent = 0;
      while (sent < answer.size()) {
        const ssize_t n = send(fd, answer.data() + sent, answer.size() - sent, MSG_NOSIGNAL);
        if (n <= 0) break;  // the client gave up (a reply over its limit)
        sent += static_cast<std::size_t>(n);
      }
    } else if (mode == Mode::kNeverAnswer) {
      // Until the client gives up and closes (recv gives 0).
      char byte;
      while (readable(fd) && recv(fd, &byte, 1, 0) > 0) {
      }
    }
    close(fd);
  }

  int listener_ = -1;
  int port_ = 0;
  std::thread thread_;
  std::promise<std::string> promise_;
  std::future<std::string> received_ = promise_.get_future();
};

std::string httpAnswer(const std::string& status_line, const std::string& body) {
  return "HTTP/1.1 " + status_line +
         "\r\nContent-Type: application/soap+xml; charset=utf-8\r\nContent-Length: " +
         std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(OnvifHttp, PostsSoap12AndReadsTheReply) {
  const std::string reply_body = "<ok/>";
  TestServer server(TestServer::Mode::kAnswer, httpAnswer("200 OK", reply_body));
  const Request r = getStatus("main");
  const std::string message = envelope(r.body, std::nullopt);
  HttpClient client;
  const Result<HttpReply> reply = client.post(server.url(), r.action, message);
  ASSERT_TRUE(reply) << reply.error();
  EXPECT_EQ(reply->status, 200);
  EXPECT_EQ(reply->body, reply_body);
  const std::string request = server.request();
  const auto end = request.find("\r\n\r\n");
  ASSERT_NE(end, std::string::npos) << request;
  const std::string headers = request.substr(0, end + 2);
  EXPECT_EQ(headers.rfind("POST /onvif/ptz HTTP/1.1\r\n", 0), 0u) << headers;
  EXPECT_TRUE(contains(headers,
                       "\r\nContent-Type: application/soap+xml; charset=utf-8; "
                       "action=\"http://www.onvif.org/ver20/ptz/wsdl/GetStatus\"\r\n"))
      << headers;
  EXPECT_TRUE(contains(headers, "\r\nContent-Length: " + std::to_string(message.size()) + "\r\n"));
  EXPECT_FALSE(contains(headers, "Expect:"));
  EXPECT_EQ(request.substr(end + 4), message);
}

TEST(OnvifHttp, AnErrorStatusKeepsItsFaultBody) {
  const std::string fault =
      "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"><s:Body><s:Fault><s:Code>"
      "<s:Value>s:Sender</s:Value><s:Subcode><s:Value>ter:NotAuthorized</s:Value></s:Subcode>"
      "</s:Code><s:Reason><s:Text xml:lang=\"en\">Sender not authorized</s:Text></s:Reason>"
      "</s:Fault></s:Body></s:Envelope>";
  for (const char* status : {"400 Bad Request", "500 Internal Server Error"}) {
    TestServer server(TestServer::Mode::kAnswer, httpAnswer(status, fault));
    HttpClient client;
    const Result<HttpReply> reply = client.post(server.url(), "urn:a", "<x/>");
    ASSERT_TRUE(reply) << reply.error();
    EXPECT_EQ(reply->status, std::atol(status));
    const Result<SoapReply> opened = openReply(reply->body, "GetStatusResponse", kPtzNs);
    ASSERT_TRUE(opened.fault());
    EXPECT_EQ(opened.fault()->subcode, "ter:NotAuthorized");
  }
}

TEST(OnvifHttp, AReplyOverTheLimitIsAborted) {
  TestServer server(TestServer::Mode::kAnswer,
                    httpAnswer("200 OK", std::string(2 * kMaxXmlBytes, 'x')));
  HttpClient client;
  const Result<HttpReply> reply = client.post(server.url(), "urn:a", "<x/>");
  ASSERT_FALSE(reply);
  EXPECT_TRUE(contains(reply.error(), "reply larger than " + std::to_string(kMaxXmlBytes)))
      << reply.error();
  // A smaller limit applies as well.
  TestServer small(TestServer::Mode::kAnswer, httpAnswer("200 OK", std::string(2000, 'x')));
  HttpOptions options;
  options.max_reply_bytes = 1000;
  EXPECT_TRUE(contains(client.post(small.url(), "urn:a", "<x/>", options).error(),
                       "reply larger than 1000 bytes"));
}

TEST(OnvifHttp, AServerThatNeverAnswersTimesOut) {
  TestServer server(TestServer::Mode::kNeverAnswer, "");
  HttpClient client;
  HttpOptions options;
  options.total_timeout_ms = 300;
  const auto start = std::chrono::steady_clock::now();
  const Result<HttpReply> reply = client.post(server.url(), "urn:a", "<x/>", options);
  const double elapsed_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  ASSERT_FALSE(reply);
  EXPECT_TRUE(contains(reply.error(), "timeout")) << reply.error();
  EXPECT_GE(elapsed_ms, 250.0);
  EXPECT_LT(elapsed_ms, 300.0 + 5000.0);  // generous: the machine may be loaded
}

TEST(OnvifHttp, ClosedConnectionAndNobodyListening) {
  {
    TestServer server(TestServer::Mode::kClose, "");
    HttpClient client;
    const Result<HttpReply> reply = client.post(server.url(), "urn:a", "<x/>");
    ASSERT_FALSE(reply);
    EXPECT_TRUE(contains(reply.error(), "closed the connection without a reply")) << reply.error();
  }
  // A port just freed: nobody listens there.
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof a;
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&a), size), 0);
  ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&a), &size), 0);
  close(fd);
  HttpClient client;
  const Result<HttpReply> reply =
      client.post("http://127.0.0.1:" + std::to_string(ntohs(a.sin_port)) + "/", "urn:a", "<x/>");
  ASSERT_FALSE(reply);
  EXPECT_TRUE(contains(reply.error(), "connection refused")) << reply.error();
  EXPECT_FALSE(client.post("http://127.0.0.1/", "urn:\"a\"", "<x/>"));
  EXPECT_FALSE(client.post("file:///etc/passwd", "urn:a", "<x/>"));
}

TEST(OnvifHttp, NoProxyFromTheEnvironment) {
  setenv("http_proxy", "http://127.0.0.1:1", 1);
  TestServer server(TestServer::Mode::kAnswer, httpAnswer("200 OK", "<ok/>"));
  HttpClient client;
  const Result<HttpReply> reply = client.post(server.url(), "urn:a", "<x/>");
  unsetenv("http_proxy");
  ASSERT_TRUE(reply) << reply.error();
  EXPECT_EQ(reply->body, "<ok/>");
}

}  // namespace
}  // namespace ptz::onvif
