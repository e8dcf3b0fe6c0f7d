// The Foxglove WebSocket protocol (subprotocol foxglove.websocket.v1,
// github.com/foxglove/ws-protocol docs/spec.md), the part without sockets: the server's JSON
// messages, the binary message-data frame, and one client's subscriptions built from its
// subscribe/unsubscribe ops. Every byte a client sends is hostile until checked: each problem is
// a status message back to that client (naming the field and the value) and a counter.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace ptz::foxglove_bridge {

constexpr const char* kSubprotocol = "foxglove.websocket.v1";

enum class StatusLevel { kInfo = 0, kWarning = 1, kError = 2 };

struct Channel {
  uint32_t id = 0;
  std::string topic;
  std::string encoding = "json";
  std::string schema_name;
  std::string schema;
  std::string schema_encoding = "jsonschema";
};

struct ServerInfo {
  std::string name;
  std::vector<std::string> capabilities;
  std::vector<std::string> supported_encodings;
  std::map<std::string, std::string> metadata;
  std::string session_id;
};

// Server -> client text messages (JSON; invalid UTF-8 in any string is replaced, never thrown on).
std::string serverInfoJson(const ServerInfo& info);
std::string advertiseJson(const std::vector<Channel>& channels);
std::string statusJson(StatusLevel level, const std::string& message);

// Server -> client binary Message Data: opcode 0x01, u32 LE subscription id, u64 LE timestamp
// (ns), payload.
constexpr uint8_t kOpMessageData = 0x01;
constexpr size_t kMessageDataHeaderBytes = 13;
std::string messageDataFrame(uint32_t subscription_id, uint64_t timestamp_ns,
                             std::string_view payload);

// What was wrong with what a client sent: the counter it goes to (`reason`) and the status
// message it gets.
struct Problem {
  StatusLevel level = StatusLevel::kError;
  std::string reason;   // bad_json, unknown_op, bad_field, unknown_channel, ...
  std::string message;  // "subscribe: subscriptions[0].channelId = 99: no such channel"
};

// What one client message changed and what was wrong with it.
struct HandleResult {
  std::vector<uint32_t> subscribed;    // subscription ids added
  std::vector<uint32_t> unsubscribed;  // subscription ids removed
  std::vector<Problem> problems;       // at most kMaxProblemsPerMessage (+1 saying how many more)
  size_t problems_total = 0;           // all of them, listed or not
};

// One client's subscriptions: subscription id -> channel id, as its ops made them.
class ClientSubscriptions {
 public:
  static constexpr size_t kMaxSubscriptions = 1024;
  static constexpr size_t kMaxProblemsPerMessage = 8;
  // A larger client message is answered with a status and not parsed (the socket's own limit,
  // above this, closes the connection).
  static constexpr size_t kMaxMessageBytes = 65536;

  // One text message. `advertised` says whether a channel id was advertised to this client.
  HandleResult handleText(std::string_view text, const std::function<bool(uint32_t)>& advertised);
  // One binary message: none is accepted (the server has no clientPublish and no services).
  HandleResult handleBinary(std::string_view bytes) const;

  // The subscription ids of a channel (empty when none).
  const std::vector<uint32_t>& of(uint32_t channel_id) const;
  size_t size() const { return channel_of_.size(); }
  // Adds the channels this client subscribes to.
  void addChannelsTo(std::set<uint32_t>* channels) const;
  bool has(uint32_t subscription_id) const { return channel_of_.count(subscription_id) > 0; }

 private:
  void subscribe(const nlohmann::json& op, HandleResult* r,
                 const std::function<bool(uint32_t)>& advertised);
  void unsubscribe(const nlohmann::json& op, HandleResult* r);

  std::map<uint32_t, uint32_t> channel_of_;                  // subscription -> channel
  std::map<uint32_t, std::vector<uint32_t>> subscriptions_;  // channel -> subscriptions
};

}  // namespace ptz::foxglove_bridge
