#include "tools/foxglove_bridge/server.hpp"

#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <future>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

namespace ptz::foxglove_bridge {
namespace {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;
using websocketpp::frame::opcode::value;

// A backed-up client is looked at again this often until it has drained.
constexpr long kRetryMs = 20;
// Problems in what one client sent printed on stderr; the rest only counted.
constexpr int kProblemsPrintedPerClient = 5;

struct Slot {
  uint64_t log_time_ns = 0;
  std::shared_ptr<const std::string> payload;  // null: nothing pending
};

struct Client {
  std::string address;
  ClientSubscriptions subscriptions;
  std::map<uint32_t, Slot> slots;  // by subscription id
  std::set<uint32_t> advertised;   // channel ids told to this client
  bool flush_posted = false;
  bool held_back = false;  // its socket is backed up: waits for the retry timer
  int problems_printed = 0;
  int64_t problems = 0;
};

}  // namespace

struct Server::Impl {
  ServerOptions options;
  WsServer ws;
  std::thread thread;
  std::future<void> thread_done;
  uint16_t port = 0;
  bool started = false;
  bool stopped = false;
  std::string session_id;

  mutable std::mutex mutex;  // everything below
  std::vector<Channel> channels;
  std::map<Hdl, Client, std::owner_less<Hdl>> clients;
  ServerStats stats;
  bool retry_timer_set = false;

  explicit Impl(ServerOptions o) : options(std::move(o)) {}

  const std::string& name() const { return options.name; }

  void setUp() {
    ws.clear_access_channels(websocketpp::log::alevel::all);
    // Its error log calls a write to a client that vanished "fatal": what matters is counted
    // (handshakes_failed, send_errors, clients) and connections are logged here.
    ws.clear_error_channels(websocketpp::log::elevel::all);
    ws.init_asio();
    ws.set_reuse_addr(true);
    ws.set_max_message_size(options.max_frame_bytes);
    ws.set_validate_handler([this](Hdl h) { return validate(h); });
    ws.set_open_handler([this](Hdl h) { onOpen(h); });
    ws.set_close_handler([this](Hdl h) { onClose(h, true); });
    ws.set_fail_handler([this](Hdl h) { onClose(h, false); });
    ws.set_message_handler([this](Hdl h, WsServer::message_ptr m) { onMessage(h, m); });
  }

  std::string remote(const Hdl& h) {
    std::error_code ec;
    auto con = ws.get_con_from_hdl(h, ec);
    if (ec) return "?";
    return con->get_remote_endpoint();
  }

  bool validate(Hdl h) {
    std::error_code ec;
    auto con = ws.get_con_from_hdl(h, ec);
    if (ec) return false;
    const auto& offered = con->get_requested_subprotocols();
    if (std::find(offered.begin(), offered.end(), kSubprotocol) == offered.end()) {
      con->set_status(websocketpp::http::status_code::bad_request);
      con->set_body(std::string("this server speaks the subprotocol ") + kSubprotocol +
                    " only (a Foxglove or Lichtblick client)\n");
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.clients_refused;
      return false;
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (clients.size() >= options.max_clients) {
        ++stats.clients_refused;
        con->set_status(websocketpp::http::status_code::service_unavailable);
        con->set_body("too many clients (" + std::to_string(options.max_clients) + ")\n");
        return false;
      }
    }
    con->select_subprotocol(kSubprotocol, ec);
    return !ec;
  }

  void onOpen(Hdl h) {
    std::vector<Channel> now;
    const std::string address = remote(h);
    size_t count = 0;
    {
      std::lock_guard<std::mutex> lock(mutex);
      Client& c = clients[h];
      c.address = address;
      now = channels;
      for (const auto& ch : channels) c.advertised.insert(ch.id);
      ++stats.clients_connected;
      count = clients.size();
      stats.clients = static_cast<int64_t>(count);
    }
    ServerInfo info;
    info.name = options.name;
    info.supported_encodings = {"json"};
    info.metadata = options.metadata;
    info.session_id = session_id;
    sendText(h, serverInfoJson(info));
    if (!now.empty()) sendText(h, advertiseJson(now));
    std::fprintf(stderr, "%s: client %s connected (%zu now)\n", name().c_str(), address.c_str(),
                 count);
  }

  void onClose(Hdl h, bool was_open) {
    std::error_code ec;
    auto con = ws.get_con_from_hdl(h, ec);
    const bool too_large =
        !ec && con->get_local_close_code() == websocketpp::close::status::message_too_big;
    std::lock_guard<std::mutex> lock(mutex);
    if (too_large) ++stats.clients_closed_too_large;
    const auto it = clients.find(h);
    if (it == clients.end()) {
      if (!was_open) ++stats.handshakes_failed;
      return;
    }
    stats.subscriptions -= static_cast<int64_t>(it->second.subscriptions.size());
    std::fprintf(stderr, "%s: client %s %s%s (%lld problems in what it sent; %zu clients now)\n",
                 name().c_str(), it->second.address.c_str(), was_open ? "disconnected" : "failed",
                 too_large ? ": a message over the size limit" : "",
                 static_cast<long long>(it->second.problems), clients.size() - 1);
    clients.erase(it);
    stats.clients = static_cast<int64_t>(clients.size());
  }

  void onMessage(Hdl h, WsServer::message_ptr m) {
    const std::string& payload = m->get_payload();
    HandleResult r;
    std::string address;
    bool print = false;
    {
      std::lock_guard<std::mutex> lock(mutex);
      const auto it = clients.find(h);
      if (it == clients.end()) return;
      Client& c = it->second;
      if (m->get_opcode() == websocketpp::frame::opcode::text) {
        r = c.subscriptions.handleText(payload,
                                       [&c](uint32_t id) { return c.advertised.count(id) > 0; });
      } else {
        r = c.subscriptions.handleBinary(payload);
      }
      for (uint32_t id : r.unsubscribed) c.slots.erase(id);
      for (uint32_t id : r.subscribed) c.slots[id] = Slot{};
      stats.subscriptions +=
          static_cast<int64_t>(r.subscribed.size()) - static_cast<int64_t>(r.unsubscribed.size());
      stats.client_errors += static_cast<int64_t>(r.problems_total);
      for (const auto& p : r.problems) ++stats.client_errors_by_reason[p.reason];
      c.problems += static_cast<int64_t>(r.problems_total);
      print = !r.problems.empty() && c.problems_printed < kProblemsPrintedPerClient;
      if (print) ++c.problems_printed;
      address = c.address;
    }
    for (const auto& p : r.problems) sendStatus(h, p.level, p.message);
    if (print) {
      std::fprintf(stderr, "%s: client %s: %s%s\n", name().c_str(), address.c_str(),
                   r.problems.front().message.c_str(), r.problems.size() > 1 ? " (and more)" : "");
    }
  }

  bool backedUp(const Hdl& h) {
    std::error_code ec;
    auto con = ws.get_con_from_hdl(h, ec);
    return ec || con->get_buffered_amount() > options.send_buffer_limit_bytes;
  }

  void sendText(const Hdl& h, const std::string& text) {
    std::error_code ec;
    ws.send(h, text, websocketpp::frame::opcode::text, ec);
    if (ec) {
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.send_errors;
    }
  }

  void sendStatus(const Hdl& h, StatusLevel level, const std::string& message) {
    if (backedUp(h)) {
      std::lock_guard<std::mutex> lock(mutex);
      ++stats.statuses_dropped;
      return;
    }
    sendText(h, statusJson(level, message));
    std::lock_guard<std::mutex> lock(mutex);
    ++stats.statuses_sent;
  }

  // On the loop's thread: every pending message of one client, unless its socket is backed up.
  void flush(Hdl h) {
    std::vector<std::pair<uint32_t, Slot>> out;
    const bool backed_up = backedUp(h);
    {
      std::lock_guard<std::mutex> lock(mutex);
      const auto it = clients.find(h);
      if (it == clients.end()) return;
      Client& c = it->second;
      c.flush_posted = false;
      if (backed_up) {
        c.held_back = true;
        ++stats.slow_client_waits;
        scheduleRetryLocked();
        return;
      }
      c.held_back = false;
      for (auto& [id, slot] : c.slots) {
        if (!slot.payload) continue;
        out.emplace_back(id, std::move(slot));
        slot = Slot{};
      }
    }
    int64_t sent = 0, bytes = 0, errors = 0;
    for (const auto& [id, slot] : out) {
      std::error_code ec;
      const std::string frame = messageDataFrame(id, slot.log_time_ns, *slot.payload);
      ws.send(h, frame, websocketpp::frame::opcode::binary, ec);
      if (ec) {
        ++errors;
        continue;
      }
      ++sent;
      bytes += static_cast<int64_t>(frame.size());
    }
    std::lock_guard<std::mutex> lock(mutex);
    stats.messages_sent += sent;
    stats.bytes_sent += bytes;
    stats.send_errors += errors;
  }

  void scheduleRetryLocked() {
    if (retry_timer_set) return;
    retry_timer_set = true;
    ws.set_timer(kRetryMs, [this](const std::error_code& ec) {
      std::vector<Hdl> held;
      {
        std::lock_guard<std::mutex> lock(mutex);
        retry_timer_set = false;
        if (ec) return;
        for (auto& [h, c] : clients) {
          if (c.held_back) held.push_back(h);
        }
      }
      for (const auto& h : held) flush(h);
    });
  }

  // On the loop's thread: channels added since each client was last told.
  void advertiseNew() {
    std::vector<std::pair<Hdl, std::vector<Channel>>> todo;
    {
      std::lock_guard<std::mutex> lock(mutex);
      for (auto& [h, c] : clients) {
        std::vector<Channel> fresh;
        for (const auto& ch : channels) {
          if (c.advertised.insert(ch.id).second) fresh.push_back(ch);
        }
        if (!fresh.empty()) todo.emplace_back(h, std::move(fresh));
      }
    }
    for (const auto& [h, fresh] : todo) sendText(h, advertiseJson(fresh));
  }

  void run() {
    for (;;) {
      try {
        ws.run();
        return;
      } catch (const std::exception& e) {  // a handler's bad_alloc: the others keep being served
        std::fprintf(stderr, "%s: the WebSocket loop caught: %s\n", name().c_str(), e.what());
      }
    }
  }
};

Server::Server(ServerOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {
  impl_->setUp();
}

Server::~Server() {
  stop();
}

void Server::start() {
  Impl& s = *impl_;
  if (s.started) return;
  const std::string where = s.options.address + ":" + std::to_string(s.options.port);
  std::error_code ec;
  const auto address = asio::ip::make_address(s.options.address, ec);
  if (ec) throw std::runtime_error("cannot listen on " + where + ": not an IP address");
  s.ws.listen(asio::ip::tcp::endpoint(address, s.options.port), ec);
  if (ec) throw std::runtime_error("cannot listen on " + where + ": " + ec.message());
  s.port = s.ws.get_local_endpoint(ec).port();
  if (ec) throw std::runtime_error("cannot listen on " + where + ": " + ec.message());
  s.ws.start_accept(ec);
  if (ec) throw std::runtime_error("cannot accept on " + where + ": " + ec.message());
  s.session_id = std::to_string(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                    std::chrono::system_clock::now().time_since_epoch())
                                    .count());
  std::packaged_task<void()> task([&s] { s.run(); });
  s.thread_done = task.get_future();
  s.thread = std::thread(std::move(task));
  s.started = true;
}

void Server::stop() {
  Impl& s = *impl_;
  if (!s.started || s.stopped) return;
  s.stopped = true;
  asio::post(s.ws.get_io_service(), [&s] {
    std::error_code ec;
    s.ws.stop_listening(ec);
    std::vector<Hdl> open;
    {
      std::lock_guard<std::mutex> lock(s.mutex);
      for (const auto& [h, c] : s.clients) open.push_back(h);
    }
    for (const auto& h : open) {
      s.ws.close(h, websocketpp::close::status::going_away, "server stopping", ec);
    }
  });
  // The loop ends once every connection has closed; a client that does not answer the close is
  // not waited for long.
  if (s.thread_done.wait_for(std::chrono::seconds(1)) != std::future_status::ready) s.ws.stop();
  s.thread.join();
}

uint16_t Server::port() const {
  return impl_->port;
}

uint32_t Server::addChannel(const std::string& topic, const std::string& encoding,
                            const std::string& schema_name, const std::string& schema,
                            const std::string& schema_encoding) {
  Impl& s = *impl_;
  uint32_t id = 0;
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    id = static_cast<uint32_t>(s.channels.size() + 1);  // 1, 2, ...
    s.channels.push_back({id, topic, encoding, schema_name, schema, schema_encoding});
  }
  if (s.started && !s.stopped) asio::post(s.ws.get_io_service(), [&s] { s.advertiseNew(); });
  return id;
}

void Server::publish(uint32_t channel_id, uint64_t log_time_ns, std::string payload) {
  Impl& s = *impl_;
  std::shared_ptr<const std::string> shared;
  std::lock_guard<std::mutex> lock(s.mutex);
  for (auto& [h, c] : s.clients) {
    const auto& subs = c.subscriptions.of(channel_id);
    if (subs.empty()) continue;
    if (!shared) shared = std::make_shared<const std::string>(std::move(payload));
    for (uint32_t id : subs) {
      Slot& slot = c.slots[id];
      if (slot.payload)
        ++(c.held_back ? s.stats.messages_dropped_slow_client : s.stats.messages_replaced);
      slot = {log_time_ns, shared};
    }
    if (!c.flush_posted && !c.held_back && s.started && !s.stopped) {
      c.flush_posted = true;
      asio::post(s.ws.get_io_service(), [&s, h = h] { s.flush(h); });
    }
  }
}

bool Server::hasClients() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return !impl_->clients.empty();
}

std::set<uint32_t> Server::subscribedChannels() const {
  std::set<uint32_t> channels;
  std::lock_guard<std::mutex> lock(impl_->mutex);
  for (const auto& [h, c] : impl_->clients) c.subscriptions.addChannelsTo(&channels);
  return channels;
}

ServerStats Server::stats() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->stats;
}

}  // namespace ptz::foxglove_bridge
