// The Foxglove WebSocket protocol layer of ptz-foxglove-bridge: the server's messages byte for
// byte (spec: github.com/foxglove/ws-protocol docs/spec.md), subscriptions as a client's ops make
// them, and every kind of hostile client message answered with the right problem.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "tools/foxglove_bridge/protocol.hpp"

using namespace ptz::foxglove_bridge;

namespace {

const auto kAdvertised = [](uint32_t id) { return id == 1 || id == 2 || id == 7; };

// The one problem a message gave.
Problem only(const HandleResult& r) {
  EXPECT_EQ(r.problems.size(), 1u);
  EXPECT_EQ(r.problems_total, 1u);
  return r.problems.empty() ? Problem{} : r.problems.front();
}

}  // namespace

TEST(FoxgloveProtocol, MessageDataFrameIsOpcodeSubscriptionTimestampPayloadLittleEndian) {
  const std::string frame = messageDataFrame(0x01020304u, 0x1122334455667788ull, "ab");
  const std::string expected(
      "\x01\x04\x03\x02\x01\x88\x77\x66\x55\x44\x33\x22\x11"
      "ab",
      15);
  EXPECT_EQ(frame, expected);
  EXPECT_EQ(messageDataFrame(0, 0, "").size(), kMessageDataHeaderBytes);
  // A payload with zero bytes inside is carried whole.
  const std::string payload("x\0y", 3);
  EXPECT_EQ(messageDataFrame(7, 1, payload).substr(13), payload);
}

TEST(FoxgloveProtocol, ServerMessagesAreTheSpecsJson) {
  EXPECT_EQ(statusJson(StatusLevel::kWarning, "careful"),
            R"({"op":"status","level":1,"message":"careful"})");
  EXPECT_EQ(statusJson(StatusLevel::kError, "x"), R"({"op":"status","level":2,"message":"x"})");
  Channel c;
  c.id = 3;
  c.topic = "/tf";
  c.schema_name = "foxglove.FrameTransforms";
  c.schema = R"({"type":"object"})";
  EXPECT_EQ(advertiseJson({c}),
            R"({"op":"advertise","channels":[{"id":3,"topic":"/tf","encoding":"json",)"
            R"("schemaName":"foxglove.FrameTransforms","schema":"{\"type\":\"object\"}",)"
            R"("schemaEncoding":"jsonschema"}]})");
  ServerInfo info;
  info.name = "ptz-foxglove-bridge";
  info.supported_encodings = {"json"};
  info.metadata = {{"lcm_url", "udpm://x"}};
  info.session_id = "42";
  EXPECT_EQ(serverInfoJson(info),
            R"({"op":"serverInfo","name":"ptz-foxglove-bridge","capabilities":[],)"
            R"("supportedEncodings":["json"],"metadata":{"lcm_url":"udpm://x"},"sessionId":"42"})");
}

TEST(FoxgloveProtocol, InvalidUtf8InAStatusIsReplacedNotThrown) {
  const std::string s = statusJson(StatusLevel::kError, std::string("bad \xff\xfe end"));
  EXPECT_NE(s.find("bad \xEF\xBF\xBD"), std::string::npos) << s;  // U+FFFD
}

TEST(FoxgloveProtocol, SubscribeAndUnsubscribe) {
  ClientSubscriptions subs;
  HandleResult r = subs.handleText(
      R"({"op":"subscribe","subscriptions":[{"id":0,"channelId":1},{"id":5,"channelId":7}]})",
      kAdvertised);
  EXPECT_TRUE(r.problems.empty());
  EXPECT_EQ(r.subscribed, (std::vector<uint32_t>{0, 5}));
  EXPECT_EQ(subs.of(1), (std::vector<uint32_t>{0}));
  EXPECT_EQ(subs.of(7), (std::vector<uint32_t>{5}));
  EXPECT_TRUE(subs.of(2).empty());
  EXPECT_EQ(subs.size(), 2u);
  r = subs.handleText(R"({"op":"unsubscribe","subscriptionIds":[0]})", kAdvertised);
  EXPECT_TRUE(r.problems.empty());
  EXPECT_EQ(r.unsubscribed, (std::vector<uint32_t>{0}));
  EXPECT_TRUE(subs.of(1).empty());
  EXPECT_FALSE(subs.has(0));
  EXPECT_TRUE(subs.has(5));
  // A freed id may be used again, for another channel; fields the spec may add are ignored.
  r = subs.handleText(R"({"op":"subscribe","subscriptions":[{"id":0,"channelId":2,"x":1}]})",
                      kAdvertised);
  EXPECT_TRUE(r.problems.empty());
  EXPECT_EQ(subs.of(2), (std::vector<uint32_t>{0}));
  // The largest id.
  r = subs.handleText(R"({"op":"subscribe","subscriptions":[{"id":4294967295,"channelId":1}]})",
                      kAdvertised);
  EXPECT_TRUE(r.problems.empty());
  EXPECT_EQ(subs.of(1), (std::vector<uint32_t>{4294967295u}));
}

TEST(FoxgloveProtocol, MalformedMessagesNameWhatIsWrong) {
  ClientSubscriptions subs;
  struct Case {
    std::string text, reason, message;
    StatusLevel level;
  };
  const std::vector<Case> cases = {
      {"not json{", "bad_json", "not JSON (9 bytes)", StatusLevel::kError},
      {"", "bad_json", "not JSON (0 bytes)", StatusLevel::kError},
      {"[1,2]", "not_an_object",
       R"(a client message must be a JSON object with an "op", got [1,2])", StatusLevel::kError},
      {R"({"subscriptions":[]})", "no_op",
       R"(op = (missing): a client message needs a string "op")", StatusLevel::kError},
      {R"({"op":17})", "no_op", R"(op = 17: a client message needs a string "op")",
       StatusLevel::kError},
      {R"({"op":"explode"})", "unknown_op", R"(op "explode": unknown)", StatusLevel::kError},
      {R"({"op":"getParameters","parameterNames":[]})", "unsupported_op",
       R"(op "getParameters" is not supported by this server (capabilities: none))",
       StatusLevel::kWarning},
      {R"({"op":"subscribe"})", "bad_field",
       "subscribe: subscriptions = (missing): must be an array of {id, channelId}",
       StatusLevel::kError},
      {R"({"op":"subscribe","subscriptions":"all"})", "bad_field",
       R"(subscribe: subscriptions = "all": must be an array of {id, channelId})",
       StatusLevel::kError},
      {R"({"op":"subscribe","subscriptions":[3]})", "bad_field",
       "subscribe: subscriptions[0] = 3: must be an object {id, channelId}", StatusLevel::kError},
      {R"({"op":"subscribe","subscriptions":[{"channelId":1}]})", "bad_field",
       "subscribe: subscriptions[0].id: missing", StatusLevel::kError},
      {R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})", "bad_field",
       "subscribe: subscriptions[0].id = -1: not an integer 0 .. 4294967295", StatusLevel::kError},
      {R"({"op":"subscribe","subscriptions":[{"id":1.5,"channelId":1}]})", "bad_field",
       "subscribe: subscriptions[0].id = 1.5: not an integer 0 .. 4294967295", StatusLevel::kError},
      {R"({"op":"subscribe","subscriptions":[{"id":4294967296,"channelId":1}]})", "bad_field",
       "subscribe: subscriptions[0].id = 4294967296: not an integer 0 .. 4294967295",
       StatusLevel::kError},
      {R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":"1"}]})", "bad_field",
       R"(subscribe: subscriptions[0].channelId = "1": not an integer 0 .. 4294967295)",
       StatusLevel::kError},
      {R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":99}]})", "unknown_channel",
       "subscribe: subscriptions[0].channelId = 99: no such channel", StatusLevel::kError},
      {R"({"op":"unsubscribe","subscriptionIds":[12]})", "unknown_subscription",
       "unsubscribe: subscriptionIds[0] = 12: no such subscription", StatusLevel::kWarning},
      {R"({"op":"unsubscribe","subscriptionIds":{"a":1}})", "bad_field",
       R"(unsubscribe: subscriptionIds = {"a":1}: must be an array of subscription ids)",
       StatusLevel::kError},
      {R"({"op":"unsubscribe","subscriptionIds":[null]})", "bad_field",
       "unsubscribe: subscriptionIds[0] = null: not an integer 0 .. 4294967295",
       StatusLevel::kError},
  };
  for (const auto& c : cases) {
    const Problem p = only(subs.handleText(c.text, kAdvertised));
    EXPECT_EQ(p.reason, c.reason) << c.text;
    EXPECT_EQ(p.message, c.message) << c.text;
    EXPECT_EQ(p.level, c.level) << c.text;
  }
  EXPECT_EQ(subs.size(), 0u);  // none of them subscribed anything
}

TEST(FoxgloveProtocol, DuplicatesAreRefusedAndTheGoodEntriesKept) {
  ClientSubscriptions subs;
  const HandleResult r = subs.handleText(
      R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":1},{"id":1,"channelId":2},)"
      R"({"id":2,"channelId":1},{"id":3,"channelId":99},{"id":4,"channelId":2}]})",
      kAdvertised);
  EXPECT_EQ(r.subscribed, (std::vector<uint32_t>{1, 4}));
  ASSERT_EQ(r.problems.size(), 3u);
  EXPECT_EQ(r.problems[0].reason, "duplicate_subscription");
  EXPECT_EQ(r.problems[0].message,
            "subscribe: subscriptions[1].id = 1: already in use (channel 1)");
  EXPECT_EQ(r.problems[1].reason, "already_subscribed");
  EXPECT_EQ(r.problems[1].level, StatusLevel::kWarning);
  EXPECT_EQ(r.problems[1].message,
            "subscribe: subscriptions[2].channelId = 1: already subscribed as subscription 1");
  EXPECT_EQ(r.problems[2].reason, "unknown_channel");
  EXPECT_EQ(subs.of(1), (std::vector<uint32_t>{1}));
  EXPECT_EQ(subs.of(2), (std::vector<uint32_t>{4}));
}

TEST(FoxgloveProtocol, ProblemsPerMessageAreCappedButAllCounted) {
  ClientSubscriptions subs;
  std::string text = R"({"op":"subscribe","subscriptions":[)";
  for (int i = 0; i < 100; ++i) text += std::string(i ? "," : "") + "{\"id\":\"x\"}";
  text += "]}";
  const HandleResult r = subs.handleText(text, kAdvertised);
  EXPECT_EQ(r.problems_total, 100u);
  ASSERT_EQ(r.problems.size(), ClientSubscriptions::kMaxProblemsPerMessage + 1);
  EXPECT_EQ(r.problems.back().reason, "more_problems");
  EXPECT_EQ(r.problems.back().message, "92 more problems in this message not listed");
}

TEST(FoxgloveProtocol, SubscriptionsPerClientAreBounded) {
  ClientSubscriptions subs;
  const auto any = [](uint32_t) { return true; };
  std::string text = R"({"op":"subscribe","subscriptions":[)";
  const size_t n = ClientSubscriptions::kMaxSubscriptions + 3;
  for (size_t i = 0; i < n; ++i) {
    text += std::string(i ? "," : "") + "{\"id\":" + std::to_string(i) +
            ",\"channelId\":" + std::to_string(i) + "}";
  }
  text += "]}";
  const HandleResult r = subs.handleText(text, any);
  EXPECT_EQ(subs.size(), ClientSubscriptions::kMaxSubscriptions);
  EXPECT_EQ(r.problems_total, 3u);
  EXPECT_EQ(r.problems[0].reason, "too_many_subscriptions");
}

TEST(FoxgloveProtocol, GiantDeepAndBinaryMessages) {
  ClientSubscriptions subs;
  // Over the limit: not parsed at all.
  const std::string giant(ClientSubscriptions::kMaxMessageBytes + 1, '{');
  Problem p = only(subs.handleText(giant, kAdvertised));
  EXPECT_EQ(p.reason, "too_large");
  EXPECT_EQ(p.message, "message of 65537 bytes not read (at most 65536)");
  // Nested as deep as the limit allows: parsed (and freed) without exhausting the stack.
  const size_t depth = ClientSubscriptions::kMaxMessageBytes / 2;
  p = only(subs.handleText(std::string(depth, '[') + std::string(depth, ']'), kAdvertised));
  EXPECT_EQ(p.reason, "not_an_object");
  p = only(subs.handleText(R"({"op":"subscribe","subscriptions":[[[[[[[[[[[[]]]]]]]]]]]]})",
                           kAdvertised));
  EXPECT_EQ(p.reason, "bad_field");
  // Binary: nothing is accepted (no clientPublish, no services).
  p = only(subs.handleBinary(std::string("\x01\x00\x00\x00\x00", 5)));
  EXPECT_EQ(p.reason, "binary_unsupported");
  EXPECT_EQ(p.message,
            "binary message (opcode 0x01, 5 bytes) not accepted: this server has no clientPublish "
            "and no services");
  EXPECT_EQ(only(subs.handleBinary("")).message,
            "binary message (opcode none, 0 bytes) not accepted: this server has no clientPublish "
            "and no services");
  // Invalid UTF-8 inside a JSON string: refused by the parser, the status still valid JSON.
  p = only(subs.handleText("{\"op\":\"\xff\"}", kAdvertised));
  EXPECT_EQ(p.reason, "bad_json");
}

TEST(FoxgloveProtocol, ClientStringsInStatusesAreCutShort) {
  ClientSubscriptions subs;
  const std::string op(1000, 'a');
  const Problem p = only(subs.handleText(R"({"op":")" + op + R"("})", kAdvertised));
  EXPECT_EQ(p.reason, "unknown_op");
  EXPECT_LT(p.message.size(), 80u);
  EXPECT_NE(p.message.find("..."), std::string::npos);
}
