// The four programs that read logs (ptz-log-summary, ptz-identify, ptz-report, ptz-replay) on
// the same bad logs: each problem its own exit code and message, the same in all four, and no
// output file or folder left behind; a cut log analysed with a warning on stderr.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <fstream>
#include <iterator>

#include "support/run_program.hpp"
#include "tools/logs/log_reader.hpp"

namespace log_exit = ptz::tools::log_exit;

namespace {

const std::string kFixture = PTZ_SOURCE_DIR "/test/fixtures/closed_loop_2s.lcmlog";

// One name per test: ctest runs this suite's tests side by side, and one test's output must not
// be taken for what another left.
std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + "log_programs_" +
         ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" + name;
}

std::string readAll(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

std::string write(const std::string& name, const std::string& bytes) {
  const std::string path = tempPath(name);
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

// A program with its output named, so that the test can look for what it left.
struct Program {
  std::string name;
  std::vector<std::string> args;  // LOG and OUT replaced
  std::string out;                // "" when it writes nothing
};

std::vector<Program> programs() {
  const std::string json = tempPath("summary.json"), report = tempPath("report"),
                    replayed = tempPath("replayed.lcmlog");
  return {
      {"ptz-log-summary", {PTZ_LOG_SUMMARY_BIN, "--log", "LOG", "--json", "OUT"}, json},
      {"ptz-identify", {PTZ_IDENTIFY_BIN, "--log", "LOG"}, ""},
      {"ptz-report", {PTZ_REPORT_BIN, "LOG", "--out", "OUT"}, report},
      // memq://: no network and no ptz-detect; every log problem is found before one is needed.
      {"ptz-replay",
       {PTZ_REPLAY_BIN, "--lcm-url", "memq://", "--log", "LOG", "--out", "OUT", "--timeout-s",
        "0.2"},
       replayed},
  };
}

ptz::test::ProgramResult run(const Program& p, const std::string& log) {
  std::vector<std::string> args = p.args;
  for (auto& a : args) {
    if (a == "LOG") a = log;
    if (a == "OUT") a = p.out;
  }
  return ptz::test::runProgram(args);
}

}  // namespace

TEST(LogPrograms, EachBadLogHasItsOwnExitCodeAndLeavesNoOutput) {
  const std::string fixture = readAll(kFixture);
  ASSERT_GT(fixture.size(), 1000u);
  ::mkdir(tempPath("folder").c_str(), 0755);
  // An LCM log of someone else's channels: the fixture's first event renamed.
  const std::string foreign = [&] {
    auto field = [&](size_t at) {
      size_t v = 0;
      for (size_t i = at; i < at + 4; ++i) v = (v << 8) | static_cast<uint8_t>(fixture[i]);
      return v;
    };
    const size_t channel_bytes = field(20), data_bytes = field(24);
    std::string b = fixture.substr(0, 28 + channel_bytes + data_bytes);
    for (size_t i = 28; i < 28 + channel_bytes; ++i) b[i] = 'Q';
    return b;
  }();
  struct Case {
    std::string log;
    int code;
    std::string message;  // after "PROGRAM: "
  };
  const std::string missing = tempPath("missing.lcmlog");
  const std::vector<Case> cases = {
      {missing, log_exit::kMissing, "log '" + missing + "': No such file or directory"},
      {tempPath("folder"), log_exit::kMissing,
       "log '" + tempPath("folder") + "': not a file (a folder)"},
      {write("empty.lcmlog", ""), log_exit::kEmpty,
       "log '" + tempPath("empty.lcmlog") + "' is empty (0 bytes)"},
      {write("first.lcmlog", fixture.substr(0, 20)), log_exit::kEmpty,
       "log '" + tempPath("first.lcmlog") +
           "' holds no complete event: it is cut inside its first (20 bytes)"},
      {write("garbage.lcmlog", std::string(5000, '\x5A')), log_exit::kNotLcm,
       "log '" + tempPath("garbage.lcmlog") +
           "' is not an LCM log: no event in its 5000 bytes (an LCM log starts with the sync "
           "word 0xEDA1DA01)"},
      {write("foreign.lcmlog", foreign), log_exit::kNoChannels,
       "log '" + tempPath("foreign.lcmlog") + "' lacks the channels needed: "},
  };
  for (const Program& p : programs()) {
    for (const Case& c : cases) {
      const auto r = run(p, c.log);
      EXPECT_EQ(r.exit_code, c.code) << p.name << " " << c.log << ": " << r.err;
      const std::string expected = p.name + ": " + c.message;
      EXPECT_EQ(r.err.substr(0, expected.size()), expected) << p.name;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << p.name << ": " << r.err;
      if (!p.out.empty()) {
        EXPECT_FALSE(exists(p.out)) << p.name << " left " << p.out;
      }
    }
  }
}

TEST(LogPrograms, ACutLogIsAnalysedAndSaysSoOnStderr) {
  const std::string fixture = readAll(kFixture);
  const std::string cut = write("cut.lcmlog", fixture.substr(0, fixture.size() * 6 / 10));
  for (const Program& p : programs()) {
    if (p.name == "ptz-replay") continue;  // needs ptz-detect (test/system/test_replay.cpp)
    const auto r = run(p, cut);
    EXPECT_EQ(r.exit_code, log_exit::kOk) << p.name << ": " << r.err;
    EXPECT_NE(r.err.find(p.name + ": warning: the log is damaged"), std::string::npos)
        << p.name << ": " << r.err;
    EXPECT_NE(
        r.err.find(cut + ": the log ends in a partial or unreadable event (cut off) at byte "),
        std::string::npos)
        << p.name << ": " << r.err;
    if (!p.out.empty()) {
      EXPECT_TRUE(exists(p.out)) << p.name;
    }
    std::system(("rm -rf '" + p.out + "'").c_str());
  }
  // Without ptz-detect, replay says so (3) and writes no --out.
  const Program replay = programs().back();
  const auto r = run(replay, cut);
  EXPECT_EQ(r.exit_code, log_exit::kUnanswered) << r.err;
  EXPECT_FALSE(exists(replay.out));
}

TEST(LogPrograms, HelpListsTheExitCodes) {
  for (const Program& p : programs()) {
    const auto r = ptz::test::runProgram({p.args[0], "--help"});
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("Exit codes: 0 done"), std::string::npos) << p.name;
    EXPECT_NE(r.out.find("7 the log lacks the channels needed"), std::string::npos) << p.name;
  }
}
