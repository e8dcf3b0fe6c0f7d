// ptz-mcap --live against a real ptz-sim over real LCM (private network namespace): it says it
// listens before the first frame, records every frame the simulator published, and the file
// reads back with the independent reader; with nothing on the network it says so (exit 7).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include "ptzstereo/process_status_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/mcap_check.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;
using Status = ptzstereo::process_status_t;

namespace {

struct Statuses {
  std::map<std::string, Status> last;
  void on(const lcm::ReceiveBuffer*, const std::string&, const Status* m) { last[m->process] = *m; }
  int64_t counter(const std::string& process, const std::string& name) const {
    const auto it = last.find(process);
    if (it == last.end()) return -1;
    for (const auto& c : it->second.counters) {
      if (c.name == name) return c.value;
    }
    return -1;
  }
  int64_t messagesIn(const std::string& process, const std::string& channel) const {
    const auto it = last.find(process);
    if (it == last.end()) return -1;
    for (const auto& c : it->second.channels) {
      if (c.channel == channel && c.direction == c.DIRECTION_IN) return c.messages;
    }
    return 0;
  }
};

}  // namespace

TEST(McapLive, EveryFrameTheSimulatorPublishedIsRecordedAndReadsBack) {
  PTZ_REQUIRE_JS();
  const std::string out = "/tmp/ptz_mcap_live_" + std::to_string(getpid()) + ".mcap";
  lcm::LCM lcm(ptz::test::kTestUrl);
  ASSERT_TRUE(lcm.good());
  Statuses statuses;
  lcm.subscribe("PROCESS_STATUS_.*", &Statuses::on, &statuses);
  ChildProcess recorder({PTZ_MCAP_BIN, "--lcm-url", ptz::test::kTestUrl, "--live", "true", "--out",
                         out, "--status_period_s", "0.2"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return statuses.last.count("ptz-mcap") > 0; }, 20s))
      << "ptz-mcap never said it listens";
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--frames", "60", "--encoding",
                    "jpeg", "--clock", "realtime"});
  ASSERT_TRUE(sim.started());
  ptz::test::handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0; }, 60s);
  ASSERT_EQ(sim.wait(0ms), 0);
  // The simulator's last status, then the recorder's that counts as many frames.
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return statuses.counter("ptz-sim", "frames_published") > 0; }, 10s));
  const int64_t published = statuses.counter("ptz-sim", "frames_published");
  ptz::test::handleUntil(
      lcm, [&] { return statuses.messagesIn("ptz-mcap", "STEREO_FRAME") >= published; }, 10s);
  EXPECT_EQ(recorder.stop(), 0);

  const ptz::test::McapSummary s = ptz::test::summarizeMcap(out, /*validate_foxglove=*/true);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  const nlohmann::json& topics = s.json["indexed"]["topics"];
  EXPECT_GE(published, 30);  // the rest skipped late on a loaded machine, if any
  EXPECT_EQ(topics["/left/image"]["count"].get<int64_t>(), published);
  EXPECT_EQ(topics["/right/camera_info"]["count"].get<int64_t>(), published);
  EXPECT_EQ(topics["/tf"]["count"].get<int64_t>(),
            published + topics["/ptz_state"]["count"].get<int64_t>());
  EXPECT_TRUE(topics.contains("/status/ptz-sim"));
  EXPECT_TRUE(topics.contains("/status/ptz-mcap"));
  for (auto it = s.json["validation"].begin(); it != s.json["validation"].end(); ++it) {
    EXPECT_EQ(it.value()["invalid"].get<int64_t>(), 0) << it.key();
  }
  ::unlink(out.c_str());
}

TEST(McapLive, NothingHeardIsExitSevenAndStillAReadableFile) {
  PTZ_REQUIRE_JS();
  const std::string out = "/tmp/ptz_mcap_quiet_" + std::to_string(getpid()) + ".mcap";
  // Nothing runs: its own status is all it hears.
  ChildProcess recorder({PTZ_MCAP_BIN, "--lcm-url", ptz::test::kTestUrl, "--live", "true", "--out",
                         out, "--duration_s", "0.5"});
  const int code = recorder.wait(20s);
  EXPECT_EQ(code, 7);
  const ptz::test::McapSummary s = ptz::test::summarizeMcap(out);
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_FALSE(s.json["indexed"]["topics"].contains("/left/image"));
  ::unlink(out.c_str());
}
