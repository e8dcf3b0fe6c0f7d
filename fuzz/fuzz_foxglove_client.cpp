// What ptz-foxglove-bridge reads from a WebSocket client (tools/foxglove_bridge/protocol.hpp):
// one client's messages, split at NUL bytes, each a text message (or, when it begins with 0x01,
// a binary one). Channels 1..8 are advertised. Properties: a subscription exists only on an
// advertised channel and exactly as the ops made it (ids said subscribed are there, ids said
// unsubscribed are gone, no more than kMaxSubscriptions); every problem has a reason and a
// message, at most kMaxProblemsPerMessage of them listed plus one line saying how many more;
// the status sent back for each is valid JSON (whatever bytes the client's values held).
#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

#include "fuzz/fuzz_support.hpp"
#include "tools/foxglove_bridge/protocol.hpp"

namespace fb = ptz::foxglove_bridge;

namespace {

constexpr uint32_t kChannels = 8;

void checkResult(const fb::HandleResult& r) {
  const size_t cap = fb::ClientSubscriptions::kMaxProblemsPerMessage;
  const bool listed_all = r.problems.size() <= cap && r.problems_total == r.problems.size();
  const bool listed_some = r.problems.size() == cap + 1 && r.problems_total > cap;
  FUZZ_CHECK(listed_all || listed_some, std::to_string(r.problems.size()) + " problems listed of " +
                                            std::to_string(r.problems_total));
  for (const fb::Problem& p : r.problems) {
    FUZZ_CHECK(!p.reason.empty() && !p.message.empty(), "a problem without reason or message");
    const std::string status = fb::statusJson(p.level, p.message);
    const auto j = nlohmann::json::parse(status, nullptr, false);
    FUZZ_CHECK(!j.is_discarded() && j.value("op", "") == "status", "status: " + status);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fb::ClientSubscriptions client;
  const auto advertised = [](uint32_t channel) { return channel >= 1 && channel <= kChannels; };
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  for (size_t at = 0; at <= input.size();) {
    const size_t end = std::min(input.find('\0', at), input.size());
    const std::string_view message = input.substr(at, end - at);
    at = end + 1;

    const size_t before = client.size();
    const bool binary = !message.empty() && message[0] == fb::kOpMessageData;
    const fb::HandleResult r =
        binary ? client.handleBinary(message) : client.handleText(message, advertised);
    checkResult(r);
    if (binary) {
      FUZZ_CHECK(r.subscribed.empty() && r.unsubscribed.empty() && client.size() == before,
                 "a binary message changed the subscriptions");
    }
    for (uint32_t id : r.subscribed) FUZZ_CHECK(client.has(id), "subscribed but absent");
    for (uint32_t id : r.unsubscribed) FUZZ_CHECK(!client.has(id), "unsubscribed but present");
    FUZZ_CHECK(client.size() + r.unsubscribed.size() == before + r.subscribed.size(),
               std::to_string(before) + " + " + std::to_string(r.subscribed.size()) + " - " +
                   std::to_string(r.unsubscribed.size()) + " != " + std::to_string(client.size()));
    FUZZ_CHECK(client.size() <= fb::ClientSubscriptions::kMaxSubscriptions,
               std::to_string(client.size()) + " subscriptions");
    size_t on_advertised = 0;
    for (uint32_t channel = 1; channel <= kChannels; ++channel) {
      for (uint32_t id : client.of(channel)) {
        FUZZ_CHECK(client.has(id), "of() lists a subscription has() denies");
        ++on_advertised;
      }
    }
    FUZZ_CHECK(on_advertised == client.size(), "a subscription on a channel never advertised");
  }
  const std::string frame = fb::messageDataFrame(7, 1'700'000'000'000'000'000u, input);
  FUZZ_CHECK(frame.size() == fb::kMessageDataHeaderBytes + size &&
                 static_cast<uint8_t>(frame[0]) == fb::kOpMessageData &&
                 frame.compare(fb::kMessageDataHeaderBytes, size, input) == 0,
             "message data frame of " + std::to_string(frame.size()) + " bytes");
  return 0;
}
