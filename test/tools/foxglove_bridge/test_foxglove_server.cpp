// The Foxglove WebSocket server of ptz-foxglove-bridge on a real socket (127.0.0.1, a free
// port), with raw WebSocket clients (ws_raw_client.hpp): a client that never reads is held back
// (the publisher never waits, its messages replaced and counted) while a reading client gets every
// newest message; once the slow one reads, it gets the newest. A second subscription id for a
// channel and garbage are answered with statuses; stop() closes with clients connected.
#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "tools/foxglove_bridge/server.hpp"
#include "tools/foxglove_bridge/ws_raw_client.hpp"

using namespace ptz::foxglove_bridge;
using namespace ptz::foxglove_bridge::test;
using namespace std::chrono_literals;

TEST(FoxgloveServer, ASlowClientIsHeldBackWhileAReadingClientGetsEveryNewestMessage) {
  ServerOptions o = loopback();
  o.send_buffer_limit_bytes = 256 * 1024;
  Server server(o);
  const uint32_t channel = server.addChannel("/big", "json", "test.Big", "{}");
  server.start();
  ASSERT_GT(server.port(), 0);

  RawClient slow(server.port(), 4096), good(server.port());
  ASSERT_TRUE(slow.ok() && good.ok());
  for (RawClient* c : {&slow, &good}) {
    EXPECT_NE(c->readText().find(R"("op":"serverInfo")"), std::string::npos);
    EXPECT_NE(c->readText().find(R"("topic":"/big")"), std::string::npos);
  }
  ASSERT_TRUE(slow.sendText(subscribe(1, channel)));
  ASSERT_TRUE(good.sendText(subscribe(9, channel)));
  ASSERT_TRUE(waitFor(server, [](const ServerStats& s) { return s.subscriptions == 2; }));

  // 200 messages of 256 kB (50 MB): the slow client reads none of them.
  constexpr int kMessages = 200;
  const std::string pad(256 * 1024, 'x');
  for (int i = 0; i < kMessages; ++i) {
    server.publish(channel, static_cast<uint64_t>(i), std::to_string(i) + " " + pad);
    long got = -1;
    while (got < i) {
      got = good.readIndex();
      ASSERT_GE(got, 0) << "the reading client got nothing after message " << i;
    }
    ASSERT_EQ(got, i);  // never an older one after a newer
  }
  const ServerStats s = server.stats();
  EXPECT_GT(s.slow_client_waits, 0);
  EXPECT_GT(s.messages_dropped_slow_client, 0);
  // The slow client got at most its socket buffers and the limit's worth: far from all 200.
  EXPECT_LT(s.messages_sent, kMessages + kMessages / 2);
  EXPECT_GE(s.messages_sent, kMessages);

  // Once it reads, it gets the newest (the retry timer sends it).
  long last = -1;
  while (last != kMessages - 1) {
    const long got = slow.readIndex();
    ASSERT_GE(got, 0) << "the slow client never got the newest message (last " << last << ")";
    ASSERT_GT(got, last);
    last = got;
  }
  EXPECT_EQ(server.stats().clients, 2);
  server.stop();  // with both connected
  int op = 0;
  std::string payload;
  while (good.readFrame(&op, &payload) && op != 8) {
  }
  EXPECT_EQ(op, 8);  // close
  ASSERT_GE(payload.size(), 2u);
  EXPECT_EQ((static_cast<unsigned char>(payload[0]) << 8) | static_cast<unsigned char>(payload[1]),
            1001);  // going away
}

TEST(FoxgloveServer, ChannelsAddedLaterAreAdvertisedAndProblemsAnswered) {
  Server server(loopback());
  server.start();
  RawClient c(server.port());
  ASSERT_TRUE(c.ok());
  EXPECT_NE(c.readText().find("serverInfo"), std::string::npos);
  const uint32_t a = server.addChannel("/a", "json", "test.A", "{}");
  EXPECT_NE(c.readText().find(R"("topic":"/a")"), std::string::npos);
  ASSERT_TRUE(c.sendText(subscribe(1, a)));
  ASSERT_TRUE(c.sendText(subscribe(2, a)));
  EXPECT_EQ(c.readText(),
            R"({"op":"status","level":1,"message":"subscribe: subscriptions[0].channelId = 1: )"
            R"(already subscribed as subscription 1"})");
  ASSERT_TRUE(c.sendText("}{"));
  EXPECT_EQ(c.readText(), R"j({"op":"status","level":2,"message":"not JSON (2 bytes)"})j");
  server.publish(a, 0x0102030405060708ull, "{}");
  int op = 0;
  std::string frame;
  ASSERT_TRUE(c.readFrame(&op, &frame));
  EXPECT_EQ(op, 2);
  EXPECT_EQ(frame, messageDataFrame(1, 0x0102030405060708ull, "{}"));
  const ServerStats s = server.stats();
  EXPECT_EQ(s.client_errors, 2);
  EXPECT_EQ(s.client_errors_by_reason.at("already_subscribed"), 1);
  EXPECT_EQ(s.client_errors_by_reason.at("bad_json"), 1);
  EXPECT_EQ(s.statuses_sent, 2);
  EXPECT_EQ(s.messages_sent, 1);
}

TEST(FoxgloveServer, APortInUseIsNamed) {
  ServerOptions o = loopback();
  Server first(o);
  first.start();
  o.port = first.port();
  Server second(o);
  try {
    second.start();
    FAIL() << "listened twice on one port";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "cannot listen on 127.0.0.1:" + std::to_string(o.port) + ": Address already in use");
  }
}
