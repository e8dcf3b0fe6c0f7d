// ptz-health on real processes over real LCM (inside a private network namespace): all OK, a
// missing process named, a starving one reported, the --watch watchdog, undecodable statuses;
// and the service manager's protocol (READY=1, WATCHDOG=1) read from a NOTIFY_SOCKET.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "common/transport/transport.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;
using Status = ptzstereo::process_status_t;

namespace {

const std::string kConfig = PTZ_SOURCE_DIR "/config/";

// The latest status of each process.
struct Statuses {
  std::map<std::string, Status> last;
  std::map<std::string, int> count;
  void on(const lcm::ReceiveBuffer*, const std::string&, const Status* m) {
    last[m->process] = *m;
    ++count[m->process];
  }
  bool okWithInput(const std::string& process, const std::string& channel) {
    auto it = last.find(process);
    if (it == last.end() || it->second.state != Status::STATE_OK) return false;
    for (const auto& c : it->second.channels) {
      if (c.channel == channel && c.rate_hz > 0) return true;
    }
    return false;
  }
};

struct HealthRun {
  int exit_code;
  std::string output;
  std::string lineOf(const std::string& process) const {
    std::istringstream in(output);
    for (std::string line; std::getline(in, line);) {
      if (line.rfind(process + " ", 0) == 0) return line;
    }
    return "";
  }
};

HealthRun health(const std::string& args) {
  const std::string out =
      ptz::test::runShell(std::string(PTZ_HEALTH_BIN) + " --lcm-url '" + ptz::test::kTestUrl +
                          "' " + args + " 2>&1; echo \"exit=$?\"");
  const auto at = out.rfind("exit=");
  return {at == std::string::npos ? -1 : std::atoi(out.c_str() + at + 5), out};
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

std::string tempDir() {
  char dir[] = "/tmp/ptz_health_XXXXXX";
  return mkdtemp(dir) ? dir : "";
}

// ptz-sim in real time and ptz-detect, up and flowing.
struct SimAndDetect {
  lcm::LCM lcm{ptz::test::kTestUrl};
  Statuses statuses;
  std::unique_ptr<ChildProcess> detect, sim;
  SimAndDetect() {
    lcm.subscribe("PROCESS_STATUS_.*", &Statuses::on, &statuses);
    detect = std::make_unique<ChildProcess>(
        std::vector<std::string>{PTZ_DETECT_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                                 kConfig + "detect_default.yaml"});
    sim = std::make_unique<ChildProcess>(std::vector<std::string>{
        PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config", kConfig + "sim_default.yaml",
        "--encoding", "jpeg", "--duration-s", "200"});
  }
  bool up() {
    return ptz::test::handleUntil(
        lcm,
        [&] {
          return statuses.count["ptz-sim"] > 0 &&
                 statuses.okWithInput("ptz-detect", "STEREO_FRAME");
        },
        30s);
  }
};

}  // namespace

TEST(HealthProcess, AllOkThenAMissingProcessByNameThenDetectStarvingWithoutTheSimulator) {
  SimAndDetect rig;
  ASSERT_TRUE(rig.up()) << "ptz-sim and ptz-detect did not come up";

  const HealthRun ok = health("--expect ptz-sim,ptz-detect");
  std::printf("%s", ok.output.c_str());
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_TRUE(contains(ok.lineOf("ptz-sim"), " OK ")) << ok.output;
  EXPECT_TRUE(contains(ok.lineOf("ptz-detect"), " OK ")) << ok.output;
  EXPECT_TRUE(contains(ok.lineOf("ptz-detect"), "STEREO_FRAME ")) << ok.output;
  EXPECT_TRUE(contains(ok.lineOf("ptz-detect"), " Hz, ")) << ok.output;

  const HealthRun missing = health("--expect ptz-sim,ptz-detect,ptz-control");
  EXPECT_EQ(missing.exit_code, 1) << missing.output;
  EXPECT_TRUE(contains(missing.lineOf("ptz-control"), "MISSING")) << missing.output;
  EXPECT_TRUE(contains(missing.lineOf("ptz-detect"), " OK ")) << missing.output;

  // Without frames ptz-detect starves: WARN after 1 s, ERROR after 5 s, and says why.
  EXPECT_EQ(rig.sim->stop(), 0);
  ASSERT_TRUE(ptz::test::handleUntil(
      rig.lcm, [&] { return rig.statuses.last["ptz-detect"].state != Status::STATE_OK; }, 10s))
      << "ptz-detect still OK without frames";
  const HealthRun starving = health("--expect ptz-sim,ptz-detect");
  std::printf("%s", starving.output.c_str());
  EXPECT_EQ(starving.exit_code, 1) << starving.output;
  const std::string detect = starving.lineOf("ptz-detect");
  EXPECT_TRUE(contains(detect, " WARN ") || contains(detect, " ERROR ")) << starving.output;
  EXPECT_TRUE(contains(detect, "no STEREO_FRAME for ")) << starving.output;
  EXPECT_TRUE(contains(starving.lineOf("ptz-sim"), "MISSING")) << starving.output;
}

TEST(HealthProcess, WatchRunsWhileAllIsWellAndExitsOneOnceAnExpectedProcessIsGoneForGrace) {
  const std::string dir = tempDir();
  ASSERT_FALSE(dir.empty());
  SimAndDetect rig;
  ASSERT_TRUE(rig.up());
  auto watch = [&](const std::string& out, const std::string& flags) {
    return std::make_unique<ChildProcess>(std::vector<std::string>{
        "/bin/sh", "-c",
        std::string("exec ") + PTZ_HEALTH_BIN + " --lcm-url '" + ptz::test::kTestUrl +
            "' --watch --expect ptz-sim,ptz-detect " + flags + " >" + out + " 2>&1"});
  };
  const auto b_start = std::chrono::steady_clock::now();
  auto stopped_cleanly = watch(dir + "/b.out", "--changes-only");
  auto watchdog = watch(dir + "/a.out", "--stale-s 1.5 --grace-s 1");
  // In watch mode ptz-health is a process too: its status counts what it heard, and what is
  // not OK (the test waits until both watchers heard both processes fine).
  auto watchers_fine = [&] {
    const Status& s = rig.statuses.last["ptz-health"];
    int64_t heard = 0, not_ok = -1;
    for (const auto& c : s.counters) {
      if (c.name == "statuses_received") heard = c.value;
      if (c.name == "processes_not_ok") not_ok = c.value;
    }
    return rig.statuses.count["ptz-health"] >= 6 && heard >= 4 && not_ok == 0;
  };
  ASSERT_TRUE(ptz::test::handleUntil(rig.lcm, watchers_fine, 20s)) << readFile(dir + "/a.out");
  // Steady for a while: the --changes-only watcher printed a table when it heard the processes
  // (and the other watcher) appear, not every second.
  ptz::test::handleUntil(
      rig.lcm, [&] { return std::chrono::steady_clock::now() - b_start > 6s; }, 10s);
  EXPECT_EQ(watchdog->wait(0ms), -1) << "the watchdog exited while all was well";
  EXPECT_EQ(stopped_cleanly->stop(), 0) << readFile(dir + "/b.out");
  const std::string b = readFile(dir + "/b.out");
  EXPECT_TRUE(contains(b, "ptz-detect")) << b;
  int tables = 0;
  for (size_t at = b.find("process "); at != std::string::npos; at = b.find("process ", at + 1)) {
    ++tables;
  }
  EXPECT_GE(tables, 1) << b;
  EXPECT_LE(tables, 3) << b;  // 6 s of watching: 6 tables without --changes-only

  EXPECT_EQ(rig.sim->stop(), 0);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(watchdog->wait(20s), 1) << readFile(dir + "/a.out");
  const double after_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string out = readFile(dir + "/a.out");
  std::printf("watchdog exited %.1f s after ptz-sim stopped (stale 1.5 s + grace 1 s)\n", after_s);
  EXPECT_GE(after_s, 1.0);  // its grace at least
  EXPECT_TRUE(contains(out, "ptz-sim has been missing, stale or ERROR")) << out;
  EXPECT_TRUE(contains(out, "STALE")) << out;
  ptz::test::runShell("rm -rf '" + dir + "'");
}

TEST(HealthProcess, UndecodableStatusesAreCountedAndTheRestJudged) {
  const std::string dir = tempDir();
  ASSERT_FALSE(dir.empty());
  lcm::LCM lcm(ptz::test::kTestUrl);
  ChildProcess one_shot({"/bin/sh", "-c",
                         std::string("exec ") + PTZ_HEALTH_BIN + " --lcm-url '" +
                             ptz::test::kTestUrl + "' --listen-s 2 >" + dir + "/out 2>&1"});
  Status fake{};
  fake.process = "ptz-fake";
  fake.hostname = "elsewhere";
  fake.pid = 77;
  std::vector<uint8_t> bytes(static_cast<size_t>(fake.getEncodedSize()));
  fake.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  const std::vector<uint8_t> garbage(300, 0xff);
  int sent_bad = 0;
  while (one_shot.wait(50ms) < 0 && sent_bad < 400) {
    lcm.publish("PROCESS_STATUS_PTZ_FAKE", bytes.data(), static_cast<unsigned>(bytes.size()));
    lcm.publish("PROCESS_STATUS_GARBAGE", garbage.data(), static_cast<unsigned>(garbage.size()));
    lcm.publish("PROCESS_STATUS_TRUNCATED", bytes.data(), static_cast<unsigned>(bytes.size() / 2));
    sent_bad += 2;
  }
  EXPECT_EQ(one_shot.wait(10s), 0) << readFile(dir + "/out");
  const std::string out = readFile(dir + "/out");
  std::printf("%s", out.c_str());
  EXPECT_TRUE(contains(out, "ptz-fake     elsewhere    77      OK")) << out;
  EXPECT_TRUE(contains(out, " status messages did not decode)")) << out;
  ptz::test::runShell("rm -rf '" + dir + "'");
}

// What a process tells the service manager, read as systemd would: datagrams on NOTIFY_SOCKET.
std::vector<std::pair<double, std::string>> notifications(const std::vector<std::string>& argv,
                                                          const std::string& dir) {
  const std::string path = dir + "/notify";
  const int fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  EXPECT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0) << path;
  setenv("NOTIFY_SOCKET", path.c_str(), 1);
  ChildProcess child(argv);
  unsetenv("NOTIFY_SOCKET");
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::pair<double, std::string>> got;
  int watchdogs = 0;
  while (watchdogs < 10 && std::chrono::steady_clock::now() - t0 < 20s) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 200) <= 0) continue;
    char buf[256];
    const ssize_t n = recv(fd, buf, sizeof buf - 1, 0);
    if (n <= 0) continue;
    got.emplace_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                     std::string(buf, static_cast<size_t>(n)));
    watchdogs += got.back().second == "WATCHDOG=1";
  }
  EXPECT_EQ(child.stop(), 0);
  close(fd);
  unlink(path.c_str());
  return got;
}

TEST(Notify, ProcessesSayReadyOnceThenFeedTheWatchdogFromTheirLoop) {
  const std::string dir = tempDir();
  ASSERT_FALSE(dir.empty());
  const std::vector<std::vector<std::string>> programs = {
      {PTZ_CONTROL_BIN, "--lcm-url", ptz::test::kTestUrl},
      {PTZ_DETECT_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
       kConfig + "detect_default.yaml"},
      {PTZ_HEALTH_BIN, "--lcm-url", ptz::test::kTestUrl, "--watch", "--grace-s", "100"}};
  for (const auto& argv : programs) {
    const auto got = notifications(argv, dir);
    ASSERT_FALSE(got.empty()) << argv[0] << " sent nothing";
    EXPECT_EQ(got.front().second, "READY=1") << argv[0];
    int ready = 0, watchdog = 0;
    double longest_gap_s = 0, last_s = got.front().first;
    for (const auto& [t, m] : got) {
      ready += m == "READY=1";
      if (m != "WATCHDOG=1") continue;
      ++watchdog;
      longest_gap_s = std::max(longest_gap_s, t - last_s);
      last_s = t;
    }
    std::printf("%s: READY=1 after %.2f s, %d WATCHDOG=1, longest gap %.2f s\n", argv[0].c_str(),
                got.front().first, watchdog, longest_gap_s);
    EXPECT_EQ(ready, 1) << argv[0];
    EXPECT_EQ(watchdog, 10) << argv[0];
    // The units' WatchdogSec is 5 s: the loop feeds it every 0.2 s, far within.
    EXPECT_LE(longest_gap_s, 1.5) << argv[0];
  }
  ptz::test::runShell("rm -rf '" + dir + "'");
}
