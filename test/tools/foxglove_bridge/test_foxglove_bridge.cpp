// The bridge's per-message work on a real server (127.0.0.1, a free port) and a raw client:
// STEREO_FRAMEs are converted only for topics a connected client subscribes to; with no
// subscription, or one to another topic, not a single image is made.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <map>
#include <string>
#include <vector>

#include "common/transport/transport.hpp"
#include "tools/foxglove_bridge/bridge.hpp"
#include "tools/foxglove_bridge/ws_raw_client.hpp"

using namespace ptz::foxglove_bridge;
using namespace ptz::foxglove_bridge::test;

namespace {

std::vector<uint8_t> frameBytes(int64_t seq) {
  const cv::Mat image(120, 160, CV_8UC3, cv::Scalar(30, 60, 90));
  const auto m = ptz::makeStereoFrame(1000 + seq * 100'000, seq, image, {0.1, 0, 1}, image,
                                      {-0.1, 0, 1}, ptzstereo::image_t::ENCODING_RAW, 80);
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// The advertised channel ids by topic, from the client's first messages.
std::map<std::string, uint32_t> advertised(RawClient* client) {
  std::map<std::string, uint32_t> ids;
  while (ids.empty()) {
    const std::string text = client->readText();
    if (text.empty()) break;
    const auto j = nlohmann::json::parse(text);
    if (j["op"] != "advertise") continue;
    for (const auto& ch : j["channels"]) ids[ch["topic"]] = ch["id"];
  }
  return ids;
}

int64_t counter(const Bridge& bridge, const std::string& name) {
  const auto c = bridge.counters();
  const auto it = c.find(name);
  return it == c.end() ? 0 : it->second;
}

}  // namespace

TEST(FoxgloveBridge, FramesAreConvertedOnlyForTopicsAClientSubscribesTo) {
  Server server(loopback());
  Bridge bridge(server, ptz::StereoRig::makeDefault(), {}, "SIM_");
  server.start();
  RawClient client(server.port());
  ASSERT_TRUE(client.ok());
  const auto ids = advertised(&client);
  ASSERT_TRUE(ids.count("/left/image") && ids.count("/ptz_state"));
  ASSERT_TRUE(waitFor(server, [](const ServerStats& s) { return s.clients == 1; }));
  int64_t seq = 0;
  const auto send = [&](int frames) {
    for (int i = 0; i < frames; ++i) {
      const auto bytes = frameBytes(++seq);
      bridge.onMessage("SIM_STEREO_FRAME", bytes.data(), bytes.size(), 1000 + seq);
    }
  };

  // Connected, subscribed to nothing: nothing converted, each frame counted.
  send(5);
  EXPECT_EQ(counter(bridge, "images_converted"), 0);
  EXPECT_EQ(counter(bridge, "messages_converted"), 0);
  EXPECT_EQ(counter(bridge, "messages_not_converted_no_subscriber"), 5);

  // Subscribed to another channel's topic only: still no image.
  ASSERT_TRUE(client.sendText(subscribe(1, ids.at("/ptz_state"))));
  ASSERT_TRUE(waitFor(server, [](const ServerStats& s) { return s.subscriptions == 1; }));
  send(5);
  EXPECT_EQ(counter(bridge, "images_converted"), 0);
  EXPECT_EQ(counter(bridge, "messages_not_converted_no_subscriber"), 10);

  // Subscribed to the left image: that image of every frame, and only it, is made and sent.
  ASSERT_TRUE(client.sendText(subscribe(2, ids.at("/left/image"))));
  ASSERT_TRUE(waitFor(server, [](const ServerStats& s) { return s.subscriptions == 2; }));
  send(3);
  EXPECT_EQ(counter(bridge, "images_converted"), 3);
  EXPECT_EQ(counter(bridge, "messages_converted"), 3);
  EXPECT_EQ(counter(bridge, "messages_not_converted_no_subscriber"), 10);
  int op = 0;
  std::string payload;
  ASSERT_TRUE(client.readFrame(&op, &payload));
  EXPECT_EQ(op, 2);  // binary message data
  EXPECT_NE(payload.find(R"("format":"jpeg")"), std::string::npos);
  server.stop();
}

TEST(FoxgloveBridge, WithNoClientNothingIsConverted) {
  Server server(loopback());
  Bridge bridge(server, ptz::StereoRig::makeDefault(), {}, "");
  const auto bytes = frameBytes(1);
  bridge.onMessage("STEREO_FRAME", bytes.data(), bytes.size(), 1000);
  EXPECT_EQ(counter(bridge, "messages_not_converted_no_client"), 1);
  EXPECT_EQ(counter(bridge, "images_converted"), 0);
  EXPECT_EQ(counter(bridge, "topics"), static_cast<int64_t>(23));
}
