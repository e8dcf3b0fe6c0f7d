#include "sim/onvif/onvif_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "common/config.hpp"
#include "ptz_driver/heads/onvif/ws_security.hpp"

namespace ptz::sim {

namespace {

constexpr size_t kMaxWriteBacklog = 1 << 20;  // a client that does not read: closed beyond
constexpr double kLingerS = 2;  // after the last answer, how long unread input is discarded

const char* reason(int status) {
  switch (status) {
    case 200:
      return "OK";
    case 400:
      return "Bad Request";
    case 401:
      return "Unauthorized";
    case 404:
      return "Not Found";
    case 405:
      return "Method Not Allowed";
    case 413:
      return "Payload Too Large";
    case 500:
      return "Internal Server Error";
    case 503:
      return "Service Unavailable";
    default:
      return "Error";
  }
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t") - a + 1);
}

int listenOn(const std::string& host, int port, int* bound_port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) throw std::runtime_error(std::string("ONVIF server: socket: ") + strerror(errno));
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  if (::inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1 ||
      ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd, 64) != 0) {
    const std::string why = strerror(errno);
    ::close(fd);
    throw std::runtime_error("ONVIF server: cannot listen on " + host + ":" + std::to_string(port) +
                             ": " + why);
  }
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  *bound_port = ntohs(a.sin_port);
  return fd;
}

// A Host header fit to be echoed in XAddrs: host name or address, optional port.
bool plainHost(const std::string& h) {
  return !h.empty() && h.size() < 256 && std::all_of(h.begin(), h.end(), [](unsigned char c) {
    return std::isalnum(c) || c == '.' || c == ':' || c == '-' || c == '[' || c == ']';
  });
}

double wallNowS() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

OnvifServer::OnvifServer(const driver::OnvifModel& model,
                         const std::array<driver::OnvifCameraSettings, 2>& cameras,
                         const OnvifServerOptions& options, const std::array<PtzPose, 2>& home)
    : options_(options) {
  for (size_t i = 0; i < 2; ++i) {
    cameras_.emplace_back(model, cameras[i], home[i]);
    digest_[i].user = cameras[i].user;
    digest_[i].password = cameras[i].password;
    digest_[i].nonce = driver::md5Hex(onvif::randomNonce());  // 32 hex digits
    const int port = options.first_port > 0 ? options.first_port + static_cast<int>(i) : 0;
    try {
      listen_fds_[i] = listenOn(options.host, port, &ports_[i]);
    } catch (...) {
      if (i == 1) ::close(listen_fds_[0]);
      throw;
    }
  }
}

OnvifServer::~OnvifServer() {
  for (const auto& c : connections_) ::close(c->fd);
  for (int fd : listen_fds_) {
    if (fd >= 0) ::close(fd);
  }
}

void OnvifServer::wait(int timeout_ms, double host_now_s) const {
  std::vector<pollfd> fds;
  for (int fd : listen_fds_) fds.push_back({fd, POLLIN, 0});
  for (const auto& c : connections_) {
    short events = c->delayed_due_s < 0 ? POLLIN : 0;
    if (!c->out.empty()) events |= POLLOUT;
    fds.push_back({c->fd, events, 0});
    if (c->delayed_due_s >= 0) {
      const int due_ms = static_cast<int>(std::ceil((c->delayed_due_s - host_now_s) * 1000));
      timeout_ms = std::clamp(due_ms, 0, timeout_ms);
    }
  }
  ::poll(fds.data(), fds.size(), timeout_ms);
}

void OnvifServer::accept(size_t camera, double host_now_s) {
  for (;;) {
    const int fd = ::accept4(listen_fds_[camera], nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;  // EAGAIN: all taken; errors: the next poll tries again
    if (connections_.size() >= options_.max_connections) {
      // Best effort: a short answer into the empty send buffer, then closed.
      static const char kBusy[] =
          "HTTP/1.1 503 Service Unavailable\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
      (void)!::send(fd, kBusy, sizeof kBusy - 1, MSG_NOSIGNAL);
      ::close(fd);
      ++counters_.connections_refused;
      continue;
    }
    auto c = std::make_unique<Connection>();
    c->fd = fd;
    c->camera = camera;
    c->last_activity_s = host_now_s;
    connections_.push_back(std::move(c));
  }
}

void OnvifServer::respond(Connection* c, int status, const std::string& body, bool close,
                          const std::string& extra_headers) {
  c->out += "HTTP/1.1 " + std::to_string(status) + " " + reason(status) + "\r\n" + extra_headers;
  if (!body.empty()) c->out += "Content-Type: application/soap+xml; charset=utf-8\r\n";
  c->out += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  c->out += close ? "Connection: close\r\n\r\n" : "Connection: keep-alive\r\n\r\n";
  c->out += body;
  c->close_after_write |= close;
}

bool OnvifServer::flush(Connection* c) {
  while (!c->out.empty()) {
    const ssize_t n = ::send(c->fd, c->out.data(), c->out.size(), MSG_NOSIGNAL);
    if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
    c->out.erase(0, static_cast<size_t>(n));
  }
  return true;
}

bool OnvifServer::handleInput(Connection* c, double host_now_s, const PtzPose& now) {
  while (c->delayed_due_s < 0 && !c->close_after_write) {
    const size_t head_end = c->in.find("\r\n\r\n");
    if (head_end == std::string::npos) {
      if (c->in.size() > options_.max_request_bytes) {
        ++counters_.bad_requests;
        respond(c, 413, "", true);
      }
      return true;  // the rest of the head is still coming
    }
    const auto bad = [&](int status) {
      ++counters_.bad_requests;
      respond(c, status, "", true);
      return true;
    };
    // Request line: METHOD SP target SP HTTP/1.x
    const size_t line_end = c->in.find("\r\n");
    const std::string line = c->in.substr(0, line_end);
    const size_t sp1 = line.find(' '), sp2 = line.rfind(' ');
    if (sp1 == std::string::npos || sp2 == sp1) return bad(400);
    const std::string method = line.substr(0, sp1), target = line.substr(sp1 + 1, sp2 - sp1 - 1),
                      version = line.substr(sp2 + 1);
    if (version != "HTTP/1.1" && version != "HTTP/1.0") return bad(400);
    if (method.empty() || target.empty() || target[0] != '/' ||
        target.find(' ') != std::string::npos) {
      return bad(400);
    }
    // Headers.
    bool keep_alive = version == "HTTP/1.1";
    long long content_length = -1;
    std::string host, authorization;
    bool expect_continue = false;
    for (size_t pos = line_end + 2; pos < head_end;) {
      const size_t eol = c->in.find("\r\n", pos);
      const std::string h = c->in.substr(pos, eol - pos);
      pos = eol + 2;
      const size_t colon = h.find(':');
      if (colon == std::string::npos || colon == 0 || h[0] == ' ' || h[0] == '\t') return bad(400);
      const std::string name = lower(h.substr(0, colon)), value = trim(h.substr(colon + 1));
      if (name == "content-length") {
        if (value.empty() || value.size() > 12 ||
            !std::all_of(value.begin(), value.end(),
                         [](unsigned char ch) { return std::isdigit(ch); })) {
          return bad(400);
        }
        const long long v = std::stoll(value);
        if (content_length >= 0 && v != content_length) return bad(400);
        content_length = v;
      } else if (name == "transfer-encoding") {
        return bad(400);  // chunked bodies: no ONVIF client sends them to a camera
      } else if (name == "connection") {
        const std::string v = lower(value);
        if (v.find("close") != std::string::npos) keep_alive = false;
        if (v.find("keep-alive") != std::string::npos) keep_alive = true;
      } else if (name == "host") {
        host = value;
      } else if (name == "authorization") {
        authorization = value;
      } else if (name == "expect") {
        expect_continue = lower(value) == "100-continue";
      }
    }
    const size_t body_bytes = content_length < 0 ? 0 : static_cast<size_t>(content_length);
    if (content_length > static_cast<long long>(options_.max_request_bytes) ||
        head_end + 4 + body_bytes > options_.max_request_bytes) {
      return bad(413);
    }
    if (c->in.size() < head_end + 4 + body_bytes) {  // the body is still coming
      // Clients that ask (.NET's, curl's above 1 KiB) wait for this before they send it.
      if (expect_continue && !c->continue_sent) c->out += "HTTP/1.1 100 Continue\r\n\r\n";
      c->continue_sent = true;
      return true;
    }
    c->continue_sent = false;
    const std::string body = c->in.substr(head_end + 4, body_bytes);
    c->in.erase(0, head_end + 4 + body_bytes);
    c->request_start_s = host_now_s;  // a pipelined next request starts now

    const std::string path = target.substr(0, target.find('?'));
    if (path != "/onvif/device_service" && path != "/onvif/media_service" &&
        path != "/onvif/ptz_service") {
      return bad(404);
    }
    if (method != "POST") return bad(405);
    std::string why;
    if (options_.http_digest &&
        !driver::digestValid(authorization, method, target, digest_[c->camera], &why)) {
      // The first request of a client comes without: that is the challenge, not a refusal.
      ++(authorization.empty() ? counters_.digest_challenges : digest_refused_);
      respond(c, 401, "", !keep_alive,
              "WWW-Authenticate: " + driver::digestChallenge(digest_[c->camera]) + "\r\n");
      continue;
    }
    const std::string our_port = std::to_string(ports_[c->camera]);
    if (!plainHost(host)) {
      host = options_.host + ":" + our_port;
    } else if (host.find(':', host.rfind(']') == std::string::npos ? 0 : host.rfind(']')) ==
               std::string::npos) {
      host += ":" + our_port;  // no port in Host: the XAddrs still need ours
    }
    const driver::OnvifReply r =
        cameras_[c->camera].handle(body, "http://" + host, now, host_now_s);
    ++counters_.requests;
    if (r.delay_s > 0) {
      Connection late;
      respond(&late, r.http_status, r.body, !keep_alive);
      c->delayed = late.out;
      c->delayed_due_s = host_now_s + r.delay_s;
      c->close_after_write = false;  // decided when it goes out
    } else {
      respond(c, r.http_status, r.body, !keep_alive);
    }
  }
  return true;
}

void OnvifServer::serve(double host_now_s, const std::array<PtzPose, 2>& now) {
  for (size_t i = 0; i < 2; ++i) accept(i, host_now_s);
  int64_t faults = 0, refused = 0;
  for (auto it = connections_.begin(); it != connections_.end();) {
    Connection* c = it->get();
    bool keep = true;
    // A late reply falls due: out it goes, and reading resumes.
    if (c->delayed_due_s >= 0 && host_now_s >= c->delayed_due_s) {
      c->close_after_write = c->delayed.find("\r\nConnection: close\r\n") != std::string::npos;
      c->out += c->delayed;
      c->delayed.clear();
      c->delayed_due_s = -1;
      c->last_activity_s = host_now_s;
    }
    if (c->closing_since_s >= 0) {
      // Lingering after the last answer: what the client still sends is discarded until it
      // closes (closing at once with unread bytes would reset the connection and could lose
      // the answer, a 413 say, before the client read it).
      char buf[16384];
      ssize_t n = 0;
      while ((n = ::recv(c->fd, buf, sizeof buf, 0)) > 0) {
      }
      const bool done = n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) ||
                        host_now_s - c->closing_since_s > kLingerS;
      if (done) {
        ::close(c->fd);
        it = connections_.erase(it);
      } else {
        ++it;
      }
      continue;
    }
    bool eof = false;
    if (c->delayed_due_s < 0 && !c->close_after_write) {
      char buf[16384];
      for (;;) {
        const ssize_t n = ::recv(c->fd, buf, sizeof buf, 0);
        if (n > 0) {
          if (c->in.empty()) c->request_start_s = host_now_s;
          c->in.append(buf, static_cast<size_t>(n));
          c->last_activity_s = host_now_s;
          if (c->in.size() > options_.max_request_bytes + sizeof buf) break;  // 413 below
          continue;
        }
        if (n == 0) {
          eof = true;  // the client is done sending: answer what it sent, then close
        } else if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
          keep = false;
        }
        break;
      }
    }
    if (keep) keep = handleInput(c, host_now_s, now[c->camera]);
    if (keep && eof && c->delayed_due_s < 0) c->close_after_write = true;
    if (keep) keep = flush(c);
    if (keep && c->out.size() > kMaxWriteBacklog) keep = false;
    if (keep && c->close_after_write && c->out.empty()) {
      ::shutdown(c->fd, SHUT_WR);
      c->closing_since_s = host_now_s;
    } else if (keep && c->delayed_due_s < 0 &&
               (host_now_s - c->last_activity_s > options_.idle_timeout_s ||
                (!c->in.empty() && host_now_s - c->request_start_s > options_.idle_timeout_s))) {
      // Silent, or trickling a request byte by byte (slowloris): either holds a connection.
      ++counters_.connections_timed_out;
      keep = false;
    }
    if (keep) {
      ++it;
    } else {
      ::close(c->fd);
      it = connections_.erase(it);
    }
  }
  for (const auto& cam : cameras_) {
    faults += cam.faults();
    refused += cam.authRefused();
  }
  counters_.soap_faults = faults;
  counters_.auth_refused = refused + digest_refused_;
}

PtzPose OnvifServer::setpoint(Side side, double host_now_s) const {
  return cameras_[static_cast<size_t>(side)].setpoint(host_now_s);
}

OnvifServerCounters OnvifServer::counters() const {
  return counters_;
}

OnvifCameras::OnvifCameras(const driver::OnvifModel& model,
                           const std::array<driver::OnvifCameraSettings, 2>& cameras,
                           const OnvifServerOptions& options, Motors motors)
    : motors_(std::move(motors)) {
  std::array<PtzPose, 2> home{};
  motors_([&home](const std::array<PtzPose, 2>& now) {
    home = now;
    return std::nullopt;
  });
  server_ = std::make_unique<OnvifServer>(model, cameras, options, home);
  applied_ = home;
  if (!options.discovery) return;
  std::vector<driver::DiscoveredCamera> found;
  for (Side side : {Side::kLeft, Side::kRight}) {
    const int port = server_->port(side);
    char endpoint[64];
    // Stable for the port: a camera keeps its endpoint across restarts.
    std::snprintf(endpoint, sizeof endpoint, "urn:uuid:5054a5a3-0000-4000-8000-%012x", port);
    found.push_back(
        {endpoint, "http://" + options.host + ":" + std::to_string(port) + "/onvif/device_service",
         std::string("ptz-sim ") + (side == Side::kLeft ? "left" : "right"), model.model});
  }
  try {
    discovery_ = std::make_unique<DiscoveryResponder>(found, options.discovery_options);
  } catch (const std::runtime_error& e) {
    // The cameras still serve HTTP; only finding them is off.
    std::fprintf(stderr, "ptz-sim: WS-Discovery off: %s\n", e.what());
  }
}

void OnvifCameras::start() {
  thread_ = std::thread([this] { serve(); });
  if (discovery_) discovery_->start();
}

void OnvifCameras::stop() {
  quit_ = true;
  if (thread_.joinable()) thread_.join();
  if (discovery_) discovery_->stop();
}

DiscoveryCounters OnvifCameras::discoveryCounters() const {
  return discovery_ ? discovery_->counters() : DiscoveryCounters{};
}

OnvifServerCounters OnvifCameras::counters() const {
  std::lock_guard<std::mutex> lock(counters_mutex_);
  return counters_;
}

void OnvifCameras::serve() {
  while (!quit_) {
    // 20 ms at most: ramps and continuous moves advance the setpoint while nothing arrives.
    server_->wait(20, wallNowS());
    motors_([this](const std::array<PtzPose, 2>& now) -> std::optional<std::array<PtzPose, 2>> {
      const double host_now_s = wallNowS();
      server_->serve(host_now_s, now);
      const std::array<PtzPose, 2> sp = {server_->setpoint(Side::kLeft, host_now_s),
                                         server_->setpoint(Side::kRight, host_now_s)};
      const auto same = [](const PtzPose& a, const PtzPose& b) {
        return a.pan_rad == b.pan_rad && a.tilt_rad == b.tilt_rad && a.zoom == b.zoom;
      };
      if (same(sp[0], applied_[0]) && same(sp[1], applied_[1])) return std::nullopt;
      applied_ = sp;
      ++setpoints_applied_;
      return sp;
    });
    std::lock_guard<std::mutex> lock(counters_mutex_);
    counters_ = server_->counters();
  }
}

std::string onvifPassword(const std::string& file) {
  return onvif::passwordFromFileOrEnv(file, "PTZ_SIM_ONVIF_PASSWORD");
}

}  // namespace ptz::sim
