#include "tools/foxglove_bridge/bridge.hpp"

#include <algorithm>
#include <set>
#include <utility>

namespace ptz::foxglove_bridge {

Bridge::Bridge(Server& server, StereoRig rig, const foxglove::ConvertOptions& options,
               std::string prefix)
    : server_(server), converter_(std::move(rig), options), prefix_(std::move(prefix)) {
  advertiseNewTopics();
}

void Bridge::onMessage(const std::string& channel, const void* data, size_t size,
                       int64_t receive_utime) {
  if (!server_.hasClients()) {
    ++not_converted_no_client_;
    return;
  }
  const std::set<uint32_t> subscribed = server_.subscribedChannels();
  const foxglove::TopicFilter wanted = [&](int topic) {
    return topic >= 0 && static_cast<size_t>(topic) < channel_ids_.size() &&
           subscribed.count(channel_ids_[static_cast<size_t>(topic)]) > 0;
  };
  // The converter knows the contract's names; the prefix only selects this rig's channels.
  auto out = converter_.convert(channel.substr(std::min(prefix_.size(), channel.size())), data,
                                size, receive_utime, wanted);
  advertiseNewTopics();
  for (auto& msg : out) {
    // Moved: an image's JSON is its JPEG in base64, not copied once more.
    server_.publish(channel_ids_[static_cast<size_t>(msg.topic)],
                    static_cast<uint64_t>(std::max<int64_t>(msg.log_time_ns, 0)),
                    std::move(msg.json));
  }
  converted_ += static_cast<int64_t>(out.size());
}

void Bridge::advertiseNewTopics() {
  const auto& topics = converter_.topics();
  while (channel_ids_.size() < topics.size()) {
    const auto& t = topics[channel_ids_.size()];
    channel_ids_.push_back(server_.addChannel(t.name, "json", t.schema_name, t.schema_json));
  }
}

std::map<std::string, int64_t> Bridge::counters() const {
  const ServerStats s = server_.stats();
  std::map<std::string, int64_t> c = {
      {"clients", s.clients},
      {"clients_connected", s.clients_connected},
      {"clients_refused", s.clients_refused},
      {"clients_closed_too_large", s.clients_closed_too_large},
      {"handshakes_failed", s.handshakes_failed},
      {"subscriptions", s.subscriptions},
      {"messages_sent", s.messages_sent},
      {"bytes_sent", s.bytes_sent},
      {"messages_replaced", s.messages_replaced},
      {"messages_dropped_slow_client", s.messages_dropped_slow_client},
      {"slow_client_waits", s.slow_client_waits},
      {"send_errors", s.send_errors},
      {"client_statuses_sent", s.statuses_sent},
      {"client_statuses_dropped", s.statuses_dropped},
      {"client_errors", s.client_errors},
      {"topics", static_cast<int64_t>(channel_ids_.size())},
      {"images_converted", converter_.imagesConverted()},
  };
  for (const auto& [reason, n] : s.client_errors_by_reason) c["client_errors_" + reason] = n;
  int64_t dropped = 0, ignored = 0;
  for (const auto& [key, n] : converter_.dropped()) dropped += n;
  for (const auto& [channel, n] : converter_.ignored()) ignored += n;
  c["converter_dropped"] = dropped;
  c["messages_ignored"] = ignored;  // channels the converter does not show
  const std::pair<const char*, int64_t> messages[] = {
      {"messages_converted", converted_},
      {"messages_not_converted_no_client", not_converted_no_client_},
      {"messages_not_converted_no_subscriber", converter_.notWanted()}};
  for (const auto& [name, n] : messages) {
    if (n > 0) c[name] = n;
  }
  return c;
}

std::map<std::string, int64_t> Bridge::takeNewDrops(std::vector<std::string>* new_reasons) {
  std::map<std::string, int64_t> by_channel;
  for (const auto& [key, n] : converter_.dropped()) {
    by_channel[key.substr(0, key.find(": "))] += n;
    int64_t& seen = drops_seen_[key];
    if (n > seen) new_reasons->push_back(key);
    seen = n;
  }
  std::map<std::string, int64_t> fresh;
  for (const auto& [channel, n] : by_channel) {
    int64_t& counted = drops_counted_[channel];
    if (n > counted) fresh[prefix_ + channel] = n - counted;
    counted = n;
  }
  return fresh;
}

}  // namespace ptz::foxglove_bridge
