// ptz-foxglove-bridge as a process, in a private network namespace: ptz-sim's live traffic over
// real LCM, served to real Foxglove WebSocket clients (test/js: @foxglove/ws-protocol's
// FoxgloveClient on `ws`). The topics advertised with their schemas, an image and a transform
// decoded, nothing more after an unsubscribe while other data flows; hostile clients answered
// with statuses while a good one is served; a port in use is an error naming address and reason.
// The clients need node and test/js/node_modules (npm ci in test/js): PTZ_REQUIRE_JS skips
// without them, or fails when PTZ_REQUIRE_JS=1.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "common/rig.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/mcap_check.hpp"
#include "support/run_program.hpp"
#include "tools/foxglove/convert.hpp"

using namespace std::chrono_literals;
using nlohmann::json;
using ptz::test::ChildProcess;
using Status = ptzstereo::process_status_t;

namespace {

constexpr const char* kBridge = "ptz-foxglove-bridge";
constexpr const char* kUrl = "ws://127.0.0.1:8765";

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The latest status of every process, by pid (two bridges may run).
struct Statuses {
  std::map<int, Status> by_pid;
  void on(const lcm::ReceiveBuffer*, const std::string&, const Status* m) { by_pid[m->pid] = *m; }
  const Status* of(int pid) const {
    const auto it = by_pid.find(pid);
    return it == by_pid.end() ? nullptr : &it->second;
  }
  int64_t counter(int pid, const std::string& name) const {
    const Status* s = of(pid);
    if (!s) return -1;
    for (const auto& c : s->counters) {
      if (c.name == name) return c.value;
    }
    return -1;
  }
};

// ptz-sim (realtime, JPEG frames at 10 Hz) and the bridge on 127.0.0.1:8765, both up.
struct BridgeRun {
  lcm::LCM lcm{ptz::test::kTestUrl};
  Statuses statuses;
  std::unique_ptr<ChildProcess> sim, bridge;
  std::string bridge_log = std::string(::testing::TempDir()) + "/foxglove_bridge.stderr";

  void start() {
    ASSERT_TRUE(lcm.good());
    lcm.subscribe("PROCESS_STATUS_.*", &Statuses::on, &statuses);
    sim = std::make_unique<ChildProcess>(
        std::vector<std::string>{PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--frame-rate-hz",
                                 "10", "--encoding", "jpeg", "--state-rate-hz", "50"});
    bridge = std::make_unique<ChildProcess>(
        std::vector<std::string>{PTZ_FOXGLOVE_BRIDGE_BIN, "--lcm-url", ptz::test::kTestUrl,
                                 "--address", "127.0.0.1", "--port", "8765"},
        bridge_log);
    ASSERT_TRUE(sim->started() && bridge->started());
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm, [&] { return statuses.of(sim->pid()) && statuses.of(bridge->pid()); }, 30s))
        << readFile(bridge_log);
  }
  int64_t counter(const std::string& name) const { return statuses.counter(bridge->pid(), name); }
  // Until the bridge's status says `connected` clients came and all have gone.
  bool clientsCameAndWent(int64_t connected) {
    return ptz::test::handleUntil(
        lcm, [&] { return counter("clients_connected") == connected && counter("clients") == 0; },
        10s);
  }
};

// A WebSocket checker's JSON, an empty object when it printed none.
json runChecker(const std::string& script, const std::vector<std::string>& args) {
  const ptz::test::JsCheckResult r = ptz::test::runJsChecker(script, args);
  EXPECT_EQ(r.exit_code, 0) << r.json.dump() << r.err;
  EXPECT_TRUE(r.json.is_object()) << r.err;
  return r.json.is_object() ? r.json : json::object();
}

}  // namespace

TEST(FoxgloveBridgeProcess, LiveTopicsReachARealFoxgloveClient) {
  PTZ_REQUIRE_JS(ptz::test::kWsCheckPackages);
  BridgeRun run;
  ASSERT_NO_FATAL_FAILURE(run.start());
  const json s = runChecker("ws_client_check.js",
                            {"--url", kUrl, "--topics", "/left/image,/tf", "--control",
                             "/right/image", "--window-ms", "1000", "--min-control", "3"});
  ASSERT_EQ(s.value("ok", false), true) << s.dump(1);

  EXPECT_EQ(s["server_info"]["name"], kBridge);
  EXPECT_EQ(s["server_info"]["capabilities"], json::array());
  EXPECT_EQ(s["server_info"]["metadata"]["lcm_url"], ptz::test::kTestUrl);
  // Every topic of the converter, each once, with its schema (JSON messages, JSON Schema).
  std::map<std::string, json> advertised;
  std::set<int64_t> ids;
  for (const auto& c : s["channels"]) {
    EXPECT_TRUE(advertised.emplace(c["topic"].get<std::string>(), c).second) << c.dump();
    EXPECT_TRUE(ids.insert(c["id"].get<int64_t>()).second) << c.dump();
    EXPECT_EQ(c["encoding"], "json");
    EXPECT_EQ(c["schema_encoding"], "jsonschema");
    EXPECT_GT(c["schema_bytes"].get<int64_t>(), 10);
  }
  const ptz::foxglove::Converter converter(ptz::StereoRig::makeDefault(), {});
  for (const auto& t : converter.topics()) {
    ASSERT_TRUE(advertised.count(t.name)) << t.name;
    EXPECT_EQ(advertised[t.name]["schema_name"], t.schema_name) << t.name;
  }
  EXPECT_EQ(advertised["/left/image"]["schema_name"], "foxglove.CompressedImage");
  EXPECT_EQ(advertised["/tf"]["schema_name"], "foxglove.FrameTransforms");
  EXPECT_EQ(advertised["/cloud"]["schema_name"], "foxglove.PointCloud");
  // A process's status topic appears once its first status is converted.
  EXPECT_EQ(advertised["/status/ptz-sim"]["schema_name"], "ptzstereo.process_status_t")
      << s["channels"].dump();

  const json& image = s["received"]["/left/image"];
  EXPECT_EQ(image["schema_name"], "foxglove.CompressedImage");
  EXPECT_EQ(image["format"], "jpeg");
  EXPECT_EQ(image["frame_id"], "left_camera");
  EXPECT_EQ(image["keys"], json({"data", "format", "frame_id", "timestamp"}));
  EXPECT_EQ(image["jpeg_soi"], true);
  EXPECT_GT(image["data_bytes"].get<int64_t>(), 1000);
  EXPECT_EQ(s["received"]["/right/image"]["frame_id"], "right_camera");
  const json& tf = s["received"]["/tf"];
  EXPECT_EQ(tf["schema_name"], "foxglove.FrameTransforms");
  std::set<std::pair<std::string, std::string>> edges;
  for (const auto& t : tf["transforms"]) {
    edges.emplace(t["parent_frame_id"].get<std::string>(), t["child_frame_id"].get<std::string>());
  }
  const std::set<std::pair<std::string, std::string>> expected = {
      {"world", "head"}, {"head", "left_camera"}, {"head", "right_camera"}};
  EXPECT_EQ(edges, expected) << tf.dump();

  // Unsubscribed: nothing more for them, while /right/image kept coming.
  EXPECT_EQ(s["after_unsubscribe"]["/left/image"], 0);
  EXPECT_EQ(s["after_unsubscribe"]["/tf"], 0);
  EXPECT_GE(s["control_after_unsubscribe"].get<int>(), 3);
  EXPECT_GE(s["window_ms"].get<int>(), 1000);
  // The marker: one status for the getParameters the server does not support.
  ASSERT_EQ(s["statuses"].size(), 1u) << s["statuses"].dump();
  EXPECT_EQ(s["statuses"][0]["level"], 1);

  // Its status counts the client, what it was sent and the one unsupported op; the client gone.
  ASSERT_TRUE(run.clientsCameAndWent(1)) << readFile(run.bridge_log);
  EXPECT_GE(run.counter("messages_sent"), 5);
  EXPECT_EQ(run.counter("client_errors"), 1);
  EXPECT_EQ(run.counter("client_errors_unsupported_op"), 1);
  EXPECT_EQ(run.statuses.of(run.bridge->pid())->state, Status::STATE_OK);
  const std::string log = readFile(run.bridge_log);
  EXPECT_NE(log.find("serving ws://127.0.0.1:8765"), std::string::npos) << log;
  EXPECT_NE(log.find("connected (1 now)"), std::string::npos) << log;
  EXPECT_EQ(run.bridge->stop(), 0) << readFile(run.bridge_log);
}

TEST(FoxgloveBridgeProcess, HostileClientsGetStatusesAndAGoodClientIsServedThroughout) {
  PTZ_REQUIRE_JS(ptz::test::kWsCheckPackages);
  BridgeRun run;
  ASSERT_NO_FATAL_FAILURE(run.start());
  const json s =
      runChecker("ws_hostile_check.js", {"--url", kUrl, "--topic", "/tf", "--min-good", "3"});
  ASSERT_EQ(s.value("ok", false), true) << s.dump(1);
  EXPECT_EQ(s["refused_without_subprotocol"], 400);
  // name -> (level, part of the message)
  const std::vector<std::tuple<std::string, int, std::string>> expected = {
      {"garbage_json", 2, "not JSON (9 bytes)"},
      {"not_an_object", 2, "must be a JSON object"},
      {"unknown_op", 2, "op \"explode\": unknown"},
      {"unknown_channel", 2, "subscriptions[0].channelId = "},
      {"wrong_types", 2, "subscriptions[0].id = -5: not an integer"},
      {"duplicate_subscription_id", 2, "subscriptions[0].id = 7: already in use"},
      {"unknown_unsubscribe", 1, "subscriptionIds[0] = 12345: no such subscription"},
      {"binary", 2, "binary message (opcode 0x01, 6 bytes) not accepted"},
      {"too_large", 2, "bytes not read (at most 65536)"},
  };
  ASSERT_EQ(s["replies"].size(), expected.size()) << s.dump(1);
  for (size_t i = 0; i < expected.size(); ++i) {
    const json& r = s["replies"][i];
    EXPECT_EQ(r["name"], std::get<0>(expected[i]));
    EXPECT_EQ(r["level"], std::get<1>(expected[i])) << r.dump();
    EXPECT_NE(r["message"].get<std::string>().find(std::get<2>(expected[i])), std::string::npos)
        << r.dump();
  }
  EXPECT_GT(s["hostile_binary_messages"].get<int>(), 0);  // its one good subscription served
  // Closed: 1009 (message too big) when the close frame arrives before the server drops the
  // rest of the 2 MB, else 1006 (the socket reset under it); the server counts it either way.
  const int close_code = s["giant_close_code"].is_number() ? s["giant_close_code"].get<int>() : 0;
  EXPECT_TRUE(close_code == 1009 || close_code == 1006) << close_code;
  EXPECT_GE(s["good_messages_after_hostile"].get<int>(), 3);
  EXPECT_GE(s["good_messages_after_giant"].get<int>(), 3);

  ASSERT_TRUE(run.clientsCameAndWent(2)) << readFile(run.bridge_log);
  EXPECT_EQ(run.counter("clients_refused"), 1);
  EXPECT_EQ(run.counter("clients_closed_too_large"), 1);
  EXPECT_EQ(run.counter("client_errors"), 9);
  EXPECT_EQ(run.counter("client_errors_bad_json"), 1);
  EXPECT_EQ(run.counter("client_errors_unknown_channel"), 1);
  EXPECT_EQ(run.counter("client_errors_too_large"), 1);
  EXPECT_EQ(run.counter("client_statuses_sent"), 9);
  EXPECT_TRUE(run.bridge->running());
  EXPECT_EQ(run.bridge->stop(), 0) << readFile(run.bridge_log);
}

TEST(FoxgloveBridgeProcess, APortInUseIsAnErrorNamingTheAddressAndTheReason) {
  BridgeRun run;
  ASSERT_NO_FATAL_FAILURE(run.start());
  const auto r = ptz::test::runProgram({PTZ_FOXGLOVE_BRIDGE_BIN, "--lcm-url", ptz::test::kTestUrl,
                                        "--address", "127.0.0.1", "--port", "8765"});
  EXPECT_EQ(r.exit_code, 4) << r.err;
  EXPECT_NE(r.err.find("cannot listen on 127.0.0.1:8765: Address already in use"),
            std::string::npos)
      << r.err;
  // Its last status says so (ERROR, the same words).
  ASSERT_TRUE(ptz::test::handleUntil(
      run.lcm,
      [&] {
        for (const auto& [pid, st] : run.statuses.by_pid) {
          if (st.process == kBridge && pid != run.bridge->pid()) return true;
        }
        return false;
      },
      10s));
  for (const auto& [pid, st] : run.statuses.by_pid) {
    if (st.process != kBridge || pid == run.bridge->pid()) continue;
    EXPECT_EQ(st.state, Status::STATE_ERROR);
    EXPECT_NE(st.message.find("Address already in use"), std::string::npos) << st.message;
  }
  // Not an IP address: named.
  const auto bad = ptz::test::runProgram(
      {PTZ_FOXGLOVE_BRIDGE_BIN, "--lcm-url", ptz::test::kTestUrl, "--address", "my-laptop"});
  EXPECT_EQ(bad.exit_code, 4);
  EXPECT_NE(bad.err.find("cannot listen on my-laptop:8765: not an IP address"), std::string::npos)
      << bad.err;
  EXPECT_TRUE(run.bridge->running());  // the first one never noticed
  EXPECT_EQ(run.bridge->stop(), 0);
}
