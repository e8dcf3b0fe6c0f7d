#include "tools/foxglove_bridge/protocol.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>
#include <set>

#include <nlohmann/json.hpp>

namespace ptz::foxglove_bridge {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;  // the spec's examples start with "op"; tests compare bytes

// Client strings may be any bytes: replaced, never thrown on.
template <class J>
std::string dump(const J& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

// A client's value in a status message: JSON, cut short.
std::string shown(const json& v) {
  constexpr size_t kMaxChars = 40;
  std::string s = dump(v);
  if (s.size() > kMaxChars) s = s.substr(0, kMaxChars) + "...";
  return s;
}

void addProblem(HandleResult* r, StatusLevel level, const std::string& reason,
                const std::string& message) {
  r->problems.push_back({level, reason, message});
}

// The problems past the cap become one line saying how many (each still counted by the caller).
void capProblems(HandleResult* r) {
  r->problems_total = r->problems.size();
  const size_t cap = ClientSubscriptions::kMaxProblemsPerMessage;
  if (r->problems.size() <= cap) return;
  const size_t more = r->problems.size() - cap;
  std::vector<Problem> kept(r->problems.begin(), r->problems.begin() + cap);
  kept.push_back({StatusLevel::kError, "more_problems",
                  std::to_string(more) + " more problems in this message not listed"});
  r->problems = std::move(kept);
}

// A client's id: a u32 (never negative here), or false and a problem naming where it was.
bool readU32(const json& v, const std::string& where, uint32_t* out, HandleResult* r) {
  const bool ok = v.is_number_unsigned() || (v.is_number_integer() && v.get<int64_t>() >= 0);
  if (!ok || v.get<uint64_t>() > std::numeric_limits<uint32_t>::max()) {
    addProblem(r, StatusLevel::kError, "bad_field",
               where + " = " + shown(v) + ": not an integer 0 .. 4294967295");
    return false;
  }
  *out = static_cast<uint32_t>(v.get<uint64_t>());
  return true;
}

// A u32 field of a client object, or a problem naming it.
bool readId(const json& object, const char* field, const std::string& where, uint32_t* out,
            HandleResult* r) {
  const auto it = object.find(field);
  if (it == object.end()) {
    addProblem(r, StatusLevel::kError, "bad_field", where + "." + field + ": missing");
    return false;
  }
  return readU32(*it, where + "." + field, out, r);
}

// The array op[field], or null and a problem naming it and what it must be.
const json* readArray(const json& op, const char* op_name, const char* field, const char* must_be,
                      HandleResult* r) {
  const auto it = op.find(field);
  if (it != op.end() && it->is_array()) return &*it;
  addProblem(r, StatusLevel::kError, "bad_field",
             std::string(op_name) + ": " + field + " = " +
                 (it == op.end() ? std::string("(missing)") : shown(*it)) + ": must be " + must_be);
  return nullptr;
}

const std::set<std::string>& unsupportedOps() {
  static const std::set<std::string> ops = {"advertise",
                                            "unadvertise",
                                            "getParameters",
                                            "setParameters",
                                            "subscribeParameterUpdates",
                                            "unsubscribeParameterUpdates",
                                            "subscribeConnectionGraph",
                                            "unsubscribeConnectionGraph",
                                            "fetchAsset"};
  return ops;
}

}  // namespace

std::string serverInfoJson(const ServerInfo& info) {
  ordered_json j;
  j["op"] = "serverInfo";
  j["name"] = info.name;
  j["capabilities"] = info.capabilities;
  j["supportedEncodings"] = info.supported_encodings;
  j["metadata"] = ordered_json::object();
  for (const auto& [k, v] : info.metadata) j["metadata"][k] = v;
  if (!info.session_id.empty()) j["sessionId"] = info.session_id;
  return dump(j);
}

std::string advertiseJson(const std::vector<Channel>& channels) {
  ordered_json j;
  j["op"] = "advertise";
  j["channels"] = ordered_json::array();
  for (const auto& c : channels) {
    ordered_json cj;
    cj["id"] = c.id;
    cj["topic"] = c.topic;
    cj["encoding"] = c.encoding;
    cj["schemaName"] = c.schema_name;
    cj["schema"] = c.schema;
    cj["schemaEncoding"] = c.schema_encoding;
    j["channels"].push_back(std::move(cj));
  }
  return dump(j);
}

std::string statusJson(StatusLevel level, const std::string& message) {
  ordered_json j;
  j["op"] = "status";
  j["level"] = static_cast<int>(level);
  j["message"] = message;
  return dump(j);
}

std::string messageDataFrame(uint32_t subscription_id, uint64_t timestamp_ns,
                             std::string_view payload) {
  std::string frame(kMessageDataHeaderBytes + payload.size(), '\0');
  frame[0] = static_cast<char>(kOpMessageData);
  for (int i = 0; i < 4; ++i) frame[1 + i] = static_cast<char>((subscription_id >> (8 * i)) & 0xff);
  for (int i = 0; i < 8; ++i) frame[5 + i] = static_cast<char>((timestamp_ns >> (8 * i)) & 0xff);
  std::copy(payload.begin(), payload.end(), frame.begin() + kMessageDataHeaderBytes);
  return frame;
}

const std::vector<uint32_t>& ClientSubscriptions::of(uint32_t channel_id) const {
  static const std::vector<uint32_t> none;
  const auto it = subscriptions_.find(channel_id);
  return it == subscriptions_.end() ? none : it->second;
}

HandleResult ClientSubscriptions::handleText(std::string_view text,
                                             const std::function<bool(uint32_t)>& advertised) {
  HandleResult r;
  if (text.size() > kMaxMessageBytes) {
    addProblem(&r, StatusLevel::kError, "too_large",
               "message of " + std::to_string(text.size()) + " bytes not read (at most " +
                   std::to_string(kMaxMessageBytes) + ")");
    capProblems(&r);
    return r;
  }
  // nlohmann's parser and destructor are iterative: deep nesting costs memory, not stack.
  const json j = json::parse(text.begin(), text.end(), nullptr, false);
  if (j.is_discarded()) {
    addProblem(&r, StatusLevel::kError, "bad_json",
               "not JSON (" + std::to_string(text.size()) + " bytes)");
    capProblems(&r);
    return r;
  }
  if (!j.is_object()) {
    addProblem(&r, StatusLevel::kError, "not_an_object",
               "a client message must be a JSON object with an \"op\", got " + shown(j));
    capProblems(&r);
    return r;
  }
  const auto op = j.find("op");
  if (op == j.end() || !op->is_string()) {
    addProblem(&r, StatusLevel::kError, "no_op",
               "op = " + (op == j.end() ? std::string("(missing)") : shown(*op)) +
                   ": a client message needs a string \"op\"");
    capProblems(&r);
    return r;
  }
  const std::string name = op->get<std::string>();
  if (name == "subscribe") {
    subscribe(j, &r, advertised);
  } else if (name == "unsubscribe") {
    unsubscribe(j, &r);
  } else if (unsupportedOps().count(name)) {
    addProblem(&r, StatusLevel::kWarning, "unsupported_op",
               "op " + shown(*op) + " is not supported by this server (capabilities: none)");
  } else {
    addProblem(&r, StatusLevel::kError, "unknown_op", "op " + shown(*op) + ": unknown");
  }
  capProblems(&r);
  return r;
}

HandleResult ClientSubscriptions::handleBinary(std::string_view bytes) const {
  HandleResult r;
  char opcode[8] = "none";
  if (!bytes.empty()) {
    std::snprintf(opcode, sizeof opcode, "0x%02x", static_cast<unsigned char>(bytes[0]));
  }
  addProblem(&r, StatusLevel::kError, "binary_unsupported",
             "binary message (opcode " + std::string(opcode) + ", " + std::to_string(bytes.size()) +
                 " bytes) not accepted: this server has no clientPublish and no services");
  r.problems_total = 1;
  return r;
}

void ClientSubscriptions::subscribe(const json& j, HandleResult* r,
                                    const std::function<bool(uint32_t)>& advertised) {
  const json* list = readArray(j, "subscribe", "subscriptions", "an array of {id, channelId}", r);
  if (!list) return;
  for (size_t i = 0; i < list->size(); ++i) {
    const json& s = (*list)[i];
    const std::string where = "subscribe: subscriptions[" + std::to_string(i) + "]";
    if (!s.is_object()) {
      addProblem(r, StatusLevel::kError, "bad_field",
                 where + " = " + shown(s) + ": must be an object {id, channelId}");
      continue;
    }
    uint32_t id = 0, channel_id = 0;
    if (!readId(s, "id", where, &id, r) || !readId(s, "channelId", where, &channel_id, r)) {
      continue;
    }
    if (channel_of_.count(id)) {
      addProblem(r, StatusLevel::kError, "duplicate_subscription",
                 where + ".id = " + std::to_string(id) + ": already in use (channel " +
                     std::to_string(channel_of_[id]) + ")");
      continue;
    }
    if (!advertised(channel_id)) {
      addProblem(r, StatusLevel::kError, "unknown_channel",
                 where + ".channelId = " + std::to_string(channel_id) + ": no such channel");
      continue;
    }
    if (!of(channel_id).empty()) {
      addProblem(r, StatusLevel::kWarning, "already_subscribed",
                 where + ".channelId = " + std::to_string(channel_id) +
                     ": already subscribed as subscription " +
                     std::to_string(of(channel_id).front()));
      continue;
    }
    if (channel_of_.size() >= kMaxSubscriptions) {
      addProblem(
          r, StatusLevel::kError, "too_many_subscriptions",
          where + ": more than " + std::to_string(kMaxSubscriptions) + " subscriptions per client");
      continue;
    }
    channel_of_[id] = channel_id;
    subscriptions_[channel_id].push_back(id);
    r->subscribed.push_back(id);
  }
}

void ClientSubscriptions::unsubscribe(const json& j, HandleResult* r) {
  const json* list =
      readArray(j, "unsubscribe", "subscriptionIds", "an array of subscription ids", r);
  if (!list) return;
  for (size_t i = 0; i < list->size(); ++i) {
    const std::string where = "unsubscribe: subscriptionIds[" + std::to_string(i) + "]";
    uint32_t id = 0;
    if (!readU32((*list)[i], where, &id, r)) continue;
    const auto it = channel_of_.find(id);
    if (it == channel_of_.end()) {
      addProblem(r, StatusLevel::kWarning, "unknown_subscription",
                 where + " = " + std::to_string(id) + ": no such subscription");
      continue;
    }
    auto& subs = subscriptions_[it->second];
    subs.erase(std::remove(subs.begin(), subs.end(), id), subs.end());
    if (subs.empty()) subscriptions_.erase(it->second);
    channel_of_.erase(it);
    r->unsubscribed.push_back(id);
  }
}

void ClientSubscriptions::addChannelsTo(std::set<uint32_t>* channels) const {
  for (const auto& [channel, ids] : subscriptions_) {
    if (!ids.empty()) channels->insert(channel);
  }
}

}  // namespace ptz::foxglove_bridge
