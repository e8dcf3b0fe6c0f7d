// ptz-health's judgement on hand-made statuses: verdicts, stale and missing processes, restarts,
// the lines it prints, the watchdog's grace and hostile names.
#include <gtest/gtest.h>

#include <algorithm>
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
