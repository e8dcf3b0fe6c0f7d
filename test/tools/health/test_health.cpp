// ptz-health's judgement on hand-made statuses: verdicts, stale and missing processes, restarts,
// the lines it prints, the watchdog's grace, hostile names and other hosts' clock offsets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>

#include "tools/health/health.hpp"

using namespace ptz::health;
using Status = ptzstereo::process_status_t;

namespace {

constexpr int64_t kT0 = 1'700'000'000'000'000;  // any wall time, µs
constexpr int64_t kSecond = 1'000'000;

Status status(const std::string& process, int8_t state = Status::STATE_OK,
              const std::string& message = "", int32_t pid = 100) {
  Status s{};
  s.process = process;
  s.hostname = "rig";
  s.pid = pid;
  s.state = state;
  s.message = message;
  return s;
}

void addInput(Status* s, const std::string& channel, double rate_hz, int64_t dropped) {
  ptzstereo::channel_status_t c{};
  c.channel = channel;
  c.direction = ptzstereo::channel_status_t::DIRECTION_IN;
  c.rate_hz = rate_hz;
  c.dropped = dropped;
  s->channels.push_back(c);
  s->num_channels = static_cast<int32_t>(s->channels.size());
}

void addCounter(Status* s, const std::string& name, int64_t value) {
  s->counters.push_back({name, value});
  s->num_counters = static_cast<int32_t>(s->counters.size());
}

const ProcessReport& find(const std::vector<ProcessReport>& reports, const std::string& name) {
  for (const auto& r : reports) {
    if (r.process == name) return r;
  }
  throw std::runtime_error("no report for " + name);
}

Options clockOptions(double max_clock_offset_ms = 5.0, const std::string& own = "listener") {
  Options o;
  o.max_clock_offset_ms = max_clock_offset_ms;
  o.own_hostname = own;
  return o;
}

// A status of `process` on `host` sent at listener time send_utime by a clock offset_us ahead,
// received latency_us later.
void sendTimed(Board* board, const std::string& process, const std::string& host,
               int64_t send_utime, int64_t offset_us, int64_t latency_us) {
  Status s = status(process);
  s.hostname = host;
  s.utime = send_utime + offset_us;
  board->onStatus(s, send_utime + latency_us);
}

HostClock clockOf(const Board& board, const std::string& host) {
  for (const auto& c : board.clocks()) {
    if (c.hostname == host) return c;
  }
  throw std::runtime_error("no clock for " + host);
}

}  // namespace

TEST(Health, EveryProcessAsItSaysItselfAndAllOkIsExitZero) {
  Board board({{"ptz-sim", "ptz-detect"}, 3.0});
  board.onStatus(status("ptz-sim"), kT0);
  board.onStatus(status("ptz-detect"), kT0 + kSecond / 2);
  const auto reports = board.judge(kT0 + kSecond);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0].process, "ptz-detect");  // in name order
  EXPECT_EQ(reports[0].verdict, Verdict::kOk);
  EXPECT_DOUBLE_EQ(reports[0].age_s, 0.5);
  EXPECT_DOUBLE_EQ(reports[1].age_s, 1.0);
  EXPECT_EQ(exitCode(reports), kExitOk);
}

TEST(Health, WarnAndErrorAreNotOk) {
  for (int8_t state : {Status::STATE_WARN, Status::STATE_ERROR, int8_t{7}}) {
    Board board({{}, 3.0});
    board.onStatus(status("ptz-sim"), kT0);
    board.onStatus(status("ptz-detect", state, "no STEREO_FRAME for 2 s"), kT0);
    const auto reports = board.judge(kT0);
    const Verdict expected = state == Status::STATE_WARN ? Verdict::kWarn : Verdict::kError;
    EXPECT_EQ(find(reports, "ptz-detect").verdict, expected) << int{state};
    EXPECT_EQ(find(reports, "ptz-sim").verdict, Verdict::kOk);
    EXPECT_EQ(exitCode(reports), kExitNotOk);
  }
}

TEST(Health, SilentForStaleSIsStaleWhateverItLastSaid) {
  Board board({{}, 3.0});
  board.onStatus(status("ptz-control"), kT0);
  EXPECT_EQ(board.judge(kT0 + 2'999'999)[0].verdict, Verdict::kOk);
  const auto reports = board.judge(kT0 + 3 * kSecond);
  EXPECT_EQ(reports[0].verdict, Verdict::kStale);
  EXPECT_EQ(exitCode(reports), kExitNotOk);
  const std::string line = formatLine(reports[0]);
  EXPECT_NE(line.find("STALE"), std::string::npos) << line;
  EXPECT_NE(line.find("no status for 3.0 s (it last said OK)"), std::string::npos) << line;
  // A fresh status makes it current again.
  board.onStatus(status("ptz-control"), kT0 + 4 * kSecond);
  EXPECT_EQ(board.judge(kT0 + 4 * kSecond)[0].verdict, Verdict::kOk);
}

TEST(Health, AnExpectedProcessNeverHeardIsMissingByName) {
  Board board({{"ptz-sim", "ptz-depth"}, 3.0});
  board.onStatus(status("ptz-sim"), kT0);
  const auto reports = board.judge(kT0);
  ASSERT_EQ(reports.size(), 2u);
  const ProcessReport& depth = find(reports, "ptz-depth");
  EXPECT_EQ(depth.verdict, Verdict::kMissing);
  EXPECT_EQ(exitCode(reports), kExitNotOk);
  const std::string line = formatLine(depth);
  EXPECT_EQ(line.rfind("ptz-depth", 0), 0u) << line;
  EXPECT_NE(line.find("MISSING"), std::string::npos) << line;
  // Nothing heard and nothing expected is no healthy system either.
  EXPECT_EQ(exitCode(Board({{}, 3.0}).judge(kT0)), kExitNotOk);
}

TEST(Health, ALineHasHostPidAgeEachInputsRateAndDropsByReasonAndTheMessage) {
  Status s = status("ptz-detect", Status::STATE_WARN, "no STEREO_FRAME for 1 s", 4242);
  addInput(&s, "STEREO_FRAME", 29.96, 7);
  ptzstereo::channel_status_t out{};
  out.channel = "OBJECT_POSE";
  out.direction = ptzstereo::channel_status_t::DIRECTION_OUT;
  out.rate_hz = 30;
  s.channels.push_back(out);
  s.num_channels = 2;
  addCounter(&s, "STEREO_FRAME.dropped_seq_gap", 5);
  addCounter(&s, "STEREO_FRAME.dropped_superseded", 2);
  addCounter(&s, "STEREO_FRAME.dropped_stale", 0);
  addCounter(&s, "dropped_seq_gap", 5);
  Board board({{}, 3.0});
  board.onStatus(s, kT0);
  const auto reports = board.judge(kT0 + 400'000);
  ASSERT_EQ(reports.size(), 1u);
  const ProcessReport& r = reports[0];
  ASSERT_EQ(r.inputs.size(), 1u);  // outputs are not inputs
  EXPECT_EQ(r.inputs[0].dropped_by_reason.size(), 2u);
  EXPECT_EQ(r.inputs[0].dropped_by_reason.at("seq_gap"), 5);
  const std::string line = formatLine(r);
  for (const char* part :
       {"ptz-detect", "rig", "4242", "WARN", "0.4 s", "STEREO_FRAME 30.0 Hz, 7 dropped",
        "(5 seq_gap, 2 superseded)", "no STEREO_FRAME for 1 s"}) {
    EXPECT_NE(line.find(part), std::string::npos) << part << " in: " << line;
  }
  EXPECT_EQ(line.find("OBJECT_POSE"), std::string::npos) << line;
  EXPECT_EQ(line.find("stale"), std::string::npos) << line;  // a zero count is not listed
  const std::string table = formatTable(reports);
  EXPECT_EQ(table.rfind("process", 0), 0u);
  EXPECT_EQ(std::count(table.begin(), table.end(), '\n'), 2);
}

TEST(Health, ANewPidIsARestartOfTheSameProcess) {
  Board board({{}, 3.0});
  board.onStatus(status("ptz-sim", Status::STATE_OK, "", 10), kT0);
  board.onStatus(status("ptz-sim", Status::STATE_OK, "", 10), kT0 + kSecond);
  board.onStatus(status("ptz-sim", Status::STATE_OK, "", 11), kT0 + 2 * kSecond);
  const auto reports = board.judge(kT0 + 2 * kSecond);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].pid, 11);
  EXPECT_EQ(reports[0].pid_changes, 1);
  EXPECT_NE(formatLine(reports[0]).find("restarted 1x"), std::string::npos);
}

TEST(Health, TheSameNameOnTwoHostsIsTwoLines) {
  Board board({{"ptz-detect"}, 3.0});
  Status a = status("ptz-detect");
  Status b = status("ptz-detect", Status::STATE_ERROR, "cannot publish");
  b.hostname = "other";
  board.onStatus(a, kT0);
  board.onStatus(b, kT0);
  const auto reports = board.judge(kT0);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(exitCode(reports), kExitNotOk);
}

TEST(Health, HostileStatusesAreBoundedAndPrintedHarmlessly) {
  Board board({{}, 3.0, 3});
  for (int i = 0; i < 10; ++i) board.onStatus(status("p" + std::to_string(i)), kT0);
  EXPECT_EQ(board.judge(kT0).size(), 3u);
  EXPECT_EQ(board.ignored(), 7);
  Board one({{}, 3.0});
  one.onStatus(status(std::string("evil\x1b[2J\n") + std::string(10000, 'x')), kT0);
  const std::string line = formatLine(one.judge(kT0)[0]);
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_EQ(line.find('\x1b'), std::string::npos);
  EXPECT_NE(line.find("evil\\x1b[2J\\x0a"), std::string::npos) << line;
  EXPECT_LT(line.size(), 400u);
}

TEST(Health, WatchdogFiresOnceAWatchedProcessIsBadForGrace) {
  Watchdog dog({"ptz-sim", "ptz-detect"}, 2.0, kT0);
  Board board({{"ptz-sim", "ptz-detect"}, 3.0});
  // Missing from the start: fires at start + grace unless it appears.
  EXPECT_EQ(dog.update(board.judge(kT0 + kSecond), kT0 + kSecond), "");
  board.onStatus(status("ptz-sim"), kT0 + kSecond);
  EXPECT_EQ(dog.update(board.judge(kT0 + 2 * kSecond), kT0 + 2 * kSecond), "ptz-detect");

  // An ERROR that clears within grace does not fire; one that lasts does.
  Watchdog dog2({"ptz-detect"}, 2.0, kT0);
  Board b2({{"ptz-detect"}, 3.0});
  b2.onStatus(status("ptz-detect", Status::STATE_ERROR), kT0);
  EXPECT_EQ(dog2.update(b2.judge(kT0), kT0), "");
  b2.onStatus(status("ptz-detect", Status::STATE_WARN), kT0 + 1'500'000);
  EXPECT_EQ(dog2.update(b2.judge(kT0 + 1'500'000), kT0 + 1'500'000), "");  // WARN is tolerated
  b2.onStatus(status("ptz-detect", Status::STATE_ERROR), kT0 + 2 * kSecond);
  EXPECT_EQ(dog2.update(b2.judge(kT0 + 2 * kSecond), kT0 + 2 * kSecond), "");
  b2.onStatus(status("ptz-detect", Status::STATE_ERROR), kT0 + 3 * kSecond);
  EXPECT_EQ(dog2.update(b2.judge(kT0 + 3 * kSecond), kT0 + 3 * kSecond), "");
  b2.onStatus(status("ptz-detect", Status::STATE_ERROR), kT0 + 4 * kSecond);
  EXPECT_EQ(dog2.update(b2.judge(kT0 + 4 * kSecond), kT0 + 4 * kSecond), "ptz-detect");

  // Stale counts from when it became stale; an unwatched process never fires.
  Watchdog dog3({"ptz-control"}, 1.0, kT0);
  Board b3({{"ptz-control"}, 3.0});
  b3.onStatus(status("ptz-control"), kT0);
  b3.onStatus(status("ptz-view", Status::STATE_ERROR), kT0);
  EXPECT_EQ(dog3.update(b3.judge(kT0), kT0), "");
  EXPECT_EQ(dog3.update(b3.judge(kT0 + 3 * kSecond), kT0 + 3 * kSecond), "");  // stale now
  EXPECT_EQ(dog3.update(b3.judge(kT0 + 3'900'000), kT0 + 3'900'000), "");
  EXPECT_EQ(dog3.update(b3.judge(kT0 + 4 * kSecond), kT0 + 4 * kSecond), "ptz-control");
}

TEST(Health, WatchdogWithNothingExpectedWatchesEveryProcessHeard) {
  Watchdog dog({}, 0.0, kT0);
  Board board({{}, 3.0});
  board.onStatus(status("ptz-depth"), kT0);
  EXPECT_EQ(dog.update(board.judge(kT0), kT0), "");
  EXPECT_EQ(dog.update(board.judge(kT0 + 3 * kSecond), kT0 + 3 * kSecond), "ptz-depth");
}

TEST(Health, ProcessListsAreChecked) {
  EXPECT_TRUE(parseProcessList("").empty());
  EXPECT_EQ(parseProcessList("ptz-sim, ptz-detect,ptz-sim"),
            (std::vector<std::string>{"ptz-sim", "ptz-detect"}));
  EXPECT_THROW(parseProcessList("ptz-sim,,ptz-detect"), std::invalid_argument);
  EXPECT_THROW(parseProcessList("ptz sim"), std::invalid_argument);
  EXPECT_THROW(parseProcessList("ptz-sim;rm"), std::invalid_argument);
}

TEST(HealthClock, KnownOffsetsAreEstimatedWithinASmallLatency) {
  Board board(clockOptions(50.0));
  std::mt19937 rng(7);
  // LAN jitter 0.2 .. 2 ms: mostly near the floor, now and then queued.
  std::exponential_distribution<double> queued_ms(1 / 0.3);
  const auto latency_ms = [&](std::mt19937& r) { return std::min(2.0, 0.2 + queued_ms(r)); };
  const std::map<std::string, double> offsets_ms = {{"host-a", 12.0}, {"host-b", -3.0}};
  std::map<std::string, std::vector<double>> window_latencies_ms;
  for (int i = 0; i < 40; ++i) {
    for (const auto& [host, offset_ms] : offsets_ms) {
      const double lat_ms = latency_ms(rng);
      if (i >= 10) window_latencies_ms[host].push_back(lat_ms);
      sendTimed(&board, "ptz-detect", host, kT0 + i * kSecond, std::llround(offset_ms * 1e3),
                std::llround(lat_ms * 1e3));
    }
  }
  for (const auto& [host, offset_ms] : offsets_ms) {
    const HostClock c = clockOf(board, host);
    EXPECT_EQ(c.statuses, kClockWindowStatuses) << host;
    EXPECT_NEAR(c.offset_ms, offset_ms, 0.3) << host;
    // Exactly the offset minus the second smallest latency in the window (µs rounding aside).
    auto lat = window_latencies_ms[host];
    std::sort(lat.begin(), lat.end());
    EXPECT_NEAR(c.offset_ms, offset_ms - lat[1], 0.002) << host;
    EXPECT_LE(c.offset_ms, offset_ms) << host;
    EXPECT_FALSE(c.own);
    EXPECT_FALSE(c.too_far);
  }
  const auto reports = board.judge(kT0 + 40 * kSecond);
  ASSERT_EQ(reports.size(), 2u);
  for (const auto& r : reports) {
    EXPECT_NEAR(r.clock_offset_ms, offsets_ms.at(r.hostname), 0.3) << r.hostname;
    EXPECT_EQ(r.verdict, Verdict::kOk) << r.hostname;  // 50 ms allowed
  }
}

TEST(HealthClock, TheWindowFollowsAClockStep) {
  Board board(clockOptions());
  for (int i = 0; i < 30; ++i) sendTimed(&board, "ptz-sim", "host-a", kT0 + i * kSecond, 1000, 500);
  EXPECT_NEAR(clockOf(board, "host-a").offset_ms, 0.5, 1e-9);
  // Stepped back 20 ms: the old, smaller delays bound the estimate until they leave the window.
  int64_t t = kT0 + 30 * kSecond;
  sendTimed(&board, "ptz-sim", "host-a", t, -20'000, 500);
  EXPECT_NEAR(clockOf(board, "host-a").offset_ms, 0.5, 1e-9);
  for (size_t i = 1; i < kClockWindowStatuses; ++i) {
    sendTimed(&board, "ptz-sim", "host-a", t += kSecond, -20'000, 500);
  }
  EXPECT_NEAR(clockOf(board, "host-a").offset_ms, -20.5, 1e-9);
  EXPECT_EQ(find(board.judge(t), "ptz-sim").verdict, Verdict::kWarn);

  // Statuses older than the window's seconds leave it too, however few there were.
  Board sparse(clockOptions());
  sendTimed(&sparse, "ptz-sim", "host-a", kT0, 0, 500);
  sendTimed(&sparse, "ptz-sim", "host-a", kT0 + kSecond, 0, 500);
  const int64_t later = kT0 + kSecond + static_cast<int64_t>(kClockWindowS * 1e6) + kSecond;
  sendTimed(&sparse, "ptz-sim", "host-a", later, 9000, 500);
  EXPECT_NEAR(clockOf(sparse, "host-a").offset_ms, 8.5, 1e-9);
  EXPECT_EQ(clockOf(sparse, "host-a").statuses, 1u);
  EXPECT_EQ(formatClocks(sparse.clocks(), 5.0), "clock  host-a       +8.5 ms (1 status)\n");
}

TEST(HealthClock, AHostPastTheThresholdMakesItsProcessesWarnByName) {
  Board board(clockOptions(5.0));
  for (int i = 0; i < 5; ++i) {
    const int64_t t = kT0 + i * kSecond;
    sendTimed(&board, "ptz-detect", "host-a", t, 12'400, 100);  // 12.3 ms ahead
    sendTimed(&board, "ptz-control", "host-b", t, -3'000, 100);
    sendTimed(&board, "ptz-depth", "host-c", t, -8'000, 100);
  }
  Status err = status("ptz-camera", Status::STATE_ERROR, "no frames");
  err.hostname = "host-a";
  err.utime = kT0 + 5 * kSecond + 12'400;
  board.onStatus(err, kT0 + 5 * kSecond + 100);
  const auto reports = board.judge(kT0 + 5 * kSecond);
  const ProcessReport& a = find(reports, "ptz-detect");
  EXPECT_EQ(a.verdict, Verdict::kWarn);
  EXPECT_NEAR(a.clock_offset_ms, 12.3, 1e-9);
  EXPECT_EQ(find(reports, "ptz-control").verdict, Verdict::kOk);  // 3.1 ms is within 5
  EXPECT_TRUE(find(reports, "ptz-control").clock_message.empty());
  EXPECT_EQ(find(reports, "ptz-depth").verdict, Verdict::kWarn);
  EXPECT_EQ(find(reports, "ptz-camera").verdict, Verdict::kError);  // at least WARN, not less
  EXPECT_EQ(exitCode(reports), kExitNotOk);
  const std::string line = formatLine(a);
  EXPECT_NE(line.find("host-a"), std::string::npos) << line;
  EXPECT_NE(line.find("clock 12.3 ms ahead of this host (max_clock_offset_ms 5): sync clocks "
                      "(chrony/PTP)"),
            std::string::npos)
      << line;
  const std::string behind = formatLine(find(reports, "ptz-depth"));
  EXPECT_NE(behind.find("clock 8.1 ms behind this host"), std::string::npos) << behind;
  const std::string clocks = formatClocks(board.clocks(), 5.0);
  EXPECT_NE(clocks.find("clock  host-a       +12.3 ms (6 statuses) over max_clock_offset_ms 5\n"),
            std::string::npos)
      << clocks;
  EXPECT_NE(clocks.find("clock  host-b       -3.1 ms (5 statuses)\n"), std::string::npos) << clocks;
  EXPECT_EQ(std::count(clocks.begin(), clocks.end(), '\n'), 3);

  // The threshold decides: 20 ms allows every host.
  Board lenient(clockOptions(20.0));
  for (int i = 0; i < 5; ++i) {
    sendTimed(&lenient, "ptz-detect", "host-a", kT0 + i * kSecond, 12'400, 100);
  }
  EXPECT_EQ(lenient.judge(kT0 + 5 * kSecond)[0].verdict, Verdict::kOk);
}

TEST(HealthClock, TheListenersOwnHostIsNeverJudgedOnClock) {
  Board board(clockOptions(5.0, "rig"));
  for (int i = 0; i < 5; ++i) sendTimed(&board, "ptz-sim", "rig", kT0 + i * kSecond, 50'000, 100);
  const auto reports = board.judge(kT0 + 5 * kSecond);
  EXPECT_EQ(reports[0].verdict, Verdict::kOk);
  EXPECT_NEAR(reports[0].clock_offset_ms, 49.9, 1e-9);  // estimated, not judged
  EXPECT_TRUE(clockOf(board, "rig").own);
  EXPECT_FALSE(clockOf(board, "rig").too_far);
  EXPECT_EQ(formatClocks(board.clocks(), 5.0), "");  // a single host has a single clock
  sendTimed(&board, "ptz-detect", "host-a", kT0 + 5 * kSecond, 0, 100);
  EXPECT_NE(formatClocks(board.clocks(), 5.0)
                .find("clock  rig          +49.9 ms (5 statuses) "
                      "this host\n"),
            std::string::npos);

  // The same statuses from another host's point of view do warn.
  Board elsewhere(clockOptions(5.0, "other"));
  for (int i = 0; i < 5; ++i) {
    sendTimed(&elsewhere, "ptz-sim", "rig", kT0 + i * kSecond, 50'000, 100);
  }
  EXPECT_EQ(elsewhere.judge(kT0 + 5 * kSecond)[0].verdict, Verdict::kWarn);
}

TEST(HealthClock, HostileSendTimesAreIgnoredWithoutHarmToOthers) {
  Board board(clockOptions(5.0));
  for (int i = 0; i < 3; ++i) sendTimed(&board, "ptz-sim", "good", kT0 + i * kSecond, 1000, 200);
  const int64_t t = kT0 + 3 * kSecond;
  int64_t n = 0;
  for (int64_t utime : {std::numeric_limits<int64_t>::min(), std::numeric_limits<int64_t>::max(),
                        int64_t{0}, t + 2 * 86'400 * kSecond}) {
    Status evil = status("ptz-evil");
    evil.hostname = "evil";
    evil.utime = utime;
    board.onStatus(evil, t);
    Status liar = status("ptz-liar");  // on the good host: must not move its estimate
    liar.hostname = "good";
    liar.utime = utime;
    board.onStatus(liar, t);
    n += 2;
  }
  Status extreme = status("ptz-evil");
  extreme.hostname = "evil";
  extreme.utime = std::numeric_limits<int64_t>::min();
  board.onStatus(extreme, std::numeric_limits<int64_t>::max());  // the widest gap there is
  ++n;
  EXPECT_EQ(board.clockIgnored(), n);
  EXPECT_NEAR(clockOf(board, "good").offset_ms, 0.8, 1e-9);
  EXPECT_EQ(clockOf(board, "good").statuses, 3u);
  EXPECT_THROW(clockOf(board, "evil"), std::runtime_error);  // no usable time, no clock
  const auto reports = board.judge(t);
  EXPECT_EQ(find(reports, "ptz-sim").verdict, Verdict::kOk);
  EXPECT_EQ(find(reports, "ptz-liar").verdict, Verdict::kOk);
  EXPECT_TRUE(std::isnan(find(reports, "ptz-evil").clock_offset_ms));
  EXPECT_TRUE(find(reports, "ptz-evil").clock_message.empty());
  // A day is the limit: just under it is a (badly) wrong clock, judged as such.
  Status far = status("ptz-far");
  far.hostname = "far";
  far.utime = t - 86'000 * kSecond;
  board.onStatus(far, t);
  EXPECT_EQ(find(board.judge(t), "ptz-far").verdict, Verdict::kOk);  // one status is no verdict
  far.utime += kSecond;
  board.onStatus(far, t + kSecond);
  EXPECT_EQ(board.clockIgnored(), n);
  EXPECT_EQ(find(board.judge(t + kSecond), "ptz-far").verdict, Verdict::kWarn);
}

// One status stamped far ahead (a stepped clock, a forged status) cannot make a host's processes
// WARN on its own: the estimate rests on the second smallest delay.
TEST(HealthClock, OneStatusStampedAheadDoesNotMoveTheHostsClock) {
  Board board(clockOptions());
  for (int i = 0; i < 10; ++i) sendTimed(&board, "ptz-sim", "host-a", kT0 + i * kSecond, 0, 500);
  sendTimed(&board, "ptz-detect", "host-a", kT0 + 10 * kSecond, 100'000, 500);
  EXPECT_NEAR(clockOf(board, "host-a").offset_ms, -0.5, 1e-9);
  for (const auto& r : board.judge(kT0 + 10 * kSecond)) {
    EXPECT_EQ(r.verdict, Verdict::kOk) << r.process << ": " << r.clock_message;
  }
  // A second one is a clock that really is ahead.
  sendTimed(&board, "ptz-detect", "host-a", kT0 + 11 * kSecond, 100'000, 500);
  EXPECT_NEAR(clockOf(board, "host-a").offset_ms, 99.5, 1e-9);
}

TEST(HealthReport, NothingHeardSaysSoAndTheKeyFollowsVerdictAndState) {
  Board board({{}, 3.0});
  const std::string empty = formatReport(board, board.judge(kT0), 5.0);
  EXPECT_NE(empty.find("(no process heard)\n"), std::string::npos) << empty;
  board.setUndecodable(2);
  board.onStatus(status("ptz-sim"), kT0);
  const auto ok = board.judge(kT0);
  const std::string text = formatReport(board, ok, 5.0);
  EXPECT_EQ(text.find("(no process heard)"), std::string::npos) << text;
  EXPECT_NE(text.find("(2 status messages did not decode)\n"), std::string::npos) << text;
  const std::string key = verdictsKey(ok);
  board.onStatus(status("ptz-sim", Status::STATE_ERROR, "broken"), kT0 + 1);
  EXPECT_NE(verdictsKey(board.judge(kT0 + 1)), key);
  EXPECT_EQ(verdictsKey(board.judge(kT0 + 2)), verdictsKey(board.judge(kT0 + 1)));
}

TEST(HealthReport, TheClockSummaryIsTheLargestOtherHostAndHowManyAreTooFar) {
  std::vector<HostClock> clocks(4);
  clocks[0] = {"listener", 50.0, 9, /*own=*/true, false};  // its own host: never counted
  clocks[1] = {"host-a", -12.5, 9, false, true};
  clocks[2] = {"host-b", 3.0, 9, false, false};
  clocks[3] = {"host-c", NAN, 0, false, false};
  const ClockSummary s = summarizeClocks(clocks);
  EXPECT_DOUBLE_EQ(s.max_abs_offset_ms, 12.5);
  EXPECT_EQ(s.hosts_too_far, 1);
}
