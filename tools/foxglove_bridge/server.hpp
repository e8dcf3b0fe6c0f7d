// A Foxglove WebSocket server (websocketpp on standalone asio, its loop on a thread of its own).
// The owner adds channels and publishes into them from its own thread without ever waiting on a
// client: each (client, subscription) holds at most one message not yet sent (a newer one
// replaces it, counted), and a client whose socket is backed up gets nothing more until it has
// drained (counted). Hostile clients get status messages and counters; the others never notice.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>

#include "tools/foxglove_bridge/protocol.hpp"

namespace ptz::foxglove_bridge {

struct ServerOptions {
  std::string name = "ptz-foxglove-bridge";
  std::string address = "0.0.0.0";
  uint16_t port = 8765;                         // 0: any free port (port() says which)
  std::map<std::string, std::string> metadata;  // in serverInfo
  size_t max_clients = 16;                      // more are refused (HTTP 503)
  // Bytes queued on a client's socket (not yet written) above which it gets nothing more.
  size_t send_buffer_limit_bytes = 8 * 1024 * 1024;
  // A client frame above this closes its connection (1009); below it and above
  // ClientSubscriptions::kMaxMessageBytes it is answered with a status.
  size_t max_frame_bytes = 1024 * 1024;
};

// Counters since start; clients is the number connected now.
struct ServerStats {
  int64_t clients = 0;
  int64_t clients_connected = 0;  // ever
  int64_t clients_refused = 0;    // no foxglove.websocket.v1 subprotocol, or too many
  int64_t clients_closed_too_large = 0;
  int64_t handshakes_failed = 0;  // not a WebSocket handshake (a scanner, a browser's HTTP GET)
  int64_t subscriptions = 0;      // now, over all clients
  int64_t messages_sent = 0;
  int64_t bytes_sent = 0;
  int64_t messages_replaced = 0;             // a newer one came before it was sent
  int64_t messages_dropped_slow_client = 0;  // replaced while its client was backed up
  int64_t slow_client_waits = 0;             // flushes held back by a backed-up socket
  int64_t send_errors = 0;
  int64_t statuses_sent = 0;
  int64_t statuses_dropped = 0;  // not sent to a backed-up client
  int64_t client_errors = 0;     // problems in what clients sent, all reasons
  std::map<std::string, int64_t> client_errors_by_reason;
};

class Server {
 public:
  explicit Server(ServerOptions options);
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds, listens and starts the loop's thread. Throws std::runtime_error "cannot listen on
  // ADDRESS:PORT: REASON" (a bad address, a port in use, no permission).
  void start();
  // Closes every connection (going away), stops listening, joins the thread. Idempotent.
  void stop();
  // The port listened on (after start()).
  uint16_t port() const;

  // Advertised to every client connected now and to each one that connects later. Thread-safe.
  uint32_t addChannel(const std::string& topic, const std::string& encoding,
                      const std::string& schema_name, const std::string& schema,
                      const std::string& schema_encoding = "jsonschema");
  // Queues payload for every subscription to the channel (one pending per subscription) and
  // returns at once. Thread-safe.
  void publish(uint32_t channel_id, uint64_t log_time_ns, std::string payload);
  // Whether any client is connected now (the owner may skip work nobody would see).
  bool hasClients() const;
  // The channels some client subscribes to now (the owner converts only what someone sees).
  std::set<uint32_t> subscribedChannels() const;
  ServerStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ptz::foxglove_bridge
