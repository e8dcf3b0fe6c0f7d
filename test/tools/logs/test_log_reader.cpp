// The log reader on logs written here byte by byte: whole, cut, damaged, empty, foreign; every
// byte accounted for in an event or a break, each problem its own error; and the outputs that
// only appear once complete.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <functional>
#include <iterator>

#include "support/error_of.hpp"
#include "tools/logs/log_reader.hpp"

using ptz::tools::LogError;
using ptz::tools::LogReader;
namespace log_exit = ptz::tools::log_exit;

namespace {

using Bytes = std::string;

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + "log_reader_" + name;
}

void put(Bytes* b, uint64_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) b->push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

// One event as LCM's logger writes it (big-endian header).
Bytes event(int64_t num, const std::string& channel, const std::string& data) {
  Bytes b;
  put(&b, 0xEDA1DA01, 4);
  put(&b, static_cast<uint64_t>(num), 8);
  put(&b, 1'700'000'000'000'000 + static_cast<uint64_t>(num), 8);
  put(&b, channel.size(), 4);
  put(&b, data.size(), 4);
  return b + channel + data;
}

std::string write(const std::string& name, const Bytes& bytes) {
  const std::string path = tempPath(name);
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

struct Read {
  std::vector<std::string> channels;
  std::vector<std::string> data;
};

Read readAll(LogReader& r) {
  Read out;
  while (const lcm::LogEvent* ev = r.next()) {
    out.channels.push_back(ev->channel);
    out.data.emplace_back(static_cast<const char*>(ev->data), static_cast<size_t>(ev->datalen));
  }
  return out;
}

// The exit code of the LogError f throws (0: none).
int codeOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const LogError& e) {
    return e.exitCode();
  }
  return 0;
}

const Bytes kA = event(0, "PTZ_STATE", "abcdef"), kB = event(1, "STEREO_FRAME", "0123456789"),
            kC = event(2, "PTZ_STATE", "xyz");

}  // namespace

TEST(LogReader, AWholeLogIsReadEventByEventWithNoBreak) {
  LogReader r(write("whole.lcmlog", kA + kB + kC));
  const Read got = readAll(r);
  EXPECT_EQ(got.channels, (std::vector<std::string>{"PTZ_STATE", "STEREO_FRAME", "PTZ_STATE"}));
  EXPECT_EQ(got.data[1], "0123456789");
  EXPECT_TRUE(r.breaks().empty());
  EXPECT_FALSE(r.truncated());
  EXPECT_EQ(r.channelEvents().at("PTZ_STATE"), 2);
  EXPECT_EQ(codeOf([&] { r.requireEvents(); }), 0);
  EXPECT_EQ(codeOf([&] { r.requireChannels({"PTZ_STATE", "STEREO_FRAME"}); }), 0);
}

TEST(LogReader, ACutLogIsReadToItsLastWholeEventAndSaysWhereItIsCut) {
  const Bytes whole = kA + kB + kC;
  for (size_t cut : {whole.size() - 1, whole.size() - kC.size() + 3, kA.size() + kB.size() + 1}) {
    LogReader r(write("cut.lcmlog", whole.substr(0, cut)));
    const Read got = readAll(r);
    EXPECT_EQ(got.channels.size(), 2u) << cut;
    ASSERT_EQ(r.breaks().size(), 1u) << cut;
    EXPECT_EQ(r.breaks()[0].offset, static_cast<int64_t>(kA.size() + kB.size())) << cut;
    EXPECT_EQ(r.breaks()[0].offset + r.breaks()[0].bytes, static_cast<int64_t>(cut));
    EXPECT_TRUE(r.truncated());
    EXPECT_EQ(r.describeBreaks(),
              r.path() + ": the log ends in a partial or unreadable event (cut off) at byte " +
                  std::to_string(kA.size() + kB.size()) + " (" +
                  std::to_string(cut - kA.size() - kB.size()) + " bytes of " + std::to_string(cut) +
                  ")\n");
  }
}

TEST(LogReader, DamageInTheMiddleIsSkippedToTheNextEventAndLocated) {
  Bytes damaged = kA + kB + kC;
  damaged[kA.size() + 22] = '\x13';  // B's channel length: 5000 and more
  LogReader r(write("damaged.lcmlog", damaged));
  EXPECT_EQ(readAll(r).channels, (std::vector<std::string>{"PTZ_STATE", "PTZ_STATE"}));
  ASSERT_EQ(r.breaks().size(), 1u);
  EXPECT_EQ(r.breaks()[0].offset, static_cast<int64_t>(kA.size()));
  EXPECT_EQ(r.breaks()[0].bytes, static_cast<int64_t>(kB.size()));
  EXPECT_FALSE(r.truncated());
  // A header whose data length runs past the end (2 GB) is not believed: nothing is allocated
  // for it, and the event after it is still read.
  Bytes lying = kA + kB + kC;
  for (int i = 0; i < 4; ++i) lying[kA.size() + 24 + i] = i == 0 ? '\x7F' : '\xFF';
  LogReader l(write("lying.lcmlog", lying));
  EXPECT_EQ(readAll(l).channels, (std::vector<std::string>{"PTZ_STATE", "PTZ_STATE"}));
  ASSERT_EQ(l.breaks().size(), 1u);
  EXPECT_EQ(l.breaks()[0].offset, static_cast<int64_t>(kA.size()));
}

TEST(LogReader, MissingEmptyForeignAndCutFirstLogsAreEachTheirOwnError) {
  EXPECT_EQ(codeOf([] { LogReader r(tempPath("no_such.lcmlog")); }), log_exit::kMissing);
  EXPECT_EQ(ptz::test::errorOf([] { LogReader r(tempPath("no_such.lcmlog")); }),
            "log '" + tempPath("no_such.lcmlog") + "': No such file or directory");
  ::mkdir(tempPath("folder.lcmlog").c_str(), 0755);
  EXPECT_EQ(ptz::test::errorOf([] { LogReader r(tempPath("folder.lcmlog")); }),
            "log '" + tempPath("folder.lcmlog") + "': not a file (a folder)");
  struct Case {
    Bytes bytes;
    int code;
    std::string message;
  };
  const std::vector<Case> cases = {
      {"", log_exit::kEmpty, "is empty (0 bytes)"},
      {kA.substr(0, 20), log_exit::kEmpty,
       "holds no complete event: it is cut inside its first (20 bytes)"},
      {"%PDF-1.4 not a log at all, not at all", log_exit::kNotLcm,
       "is not an LCM log: no event in its 37 bytes (an LCM log starts with the sync word "
       "0xEDA1DA01)"},
  };
  for (const auto& c : cases) {
    const std::string path = write("bad.lcmlog", c.bytes);
    LogReader r(path);
    EXPECT_EQ(r.next(), nullptr);
    EXPECT_EQ(codeOf([&] { r.requireEvents(); }), c.code) << c.message;
    EXPECT_EQ(ptz::test::errorOf([&] { r.requireEvents(); }), "log '" + path + "' " + c.message);
  }
  // An LCM log of other channels.
  const std::string path = write("foreign.lcmlog", event(0, "POSE", "p") + event(1, "POSE", "q"));
  LogReader r(path);
  readAll(r);
  EXPECT_EQ(codeOf([&] {
              r.requireChannels({"PTZ_STATE"}, {"STEREO_FRAME", "SIM_TRUTH"});
            }),
            log_exit::kNoChannels);
  EXPECT_EQ(ptz::test::errorOf([&] {
              r.requireChannels({"PTZ_STATE"}, {"STEREO_FRAME", "SIM_TRUTH"});
            }),
            "log '" + path +
                "' lacks the channels needed: no PTZ_STATE, none of STEREO_FRAME, SIM_TRUTH; it "
                "has POSE (2)");
}

TEST(OutputFiles, AppearUnderTheirNameOnlyWhenCommitted) {
  const std::string path = tempPath("out.json");
  std::remove(path.c_str());
  std::string temp;
  {
    ptz::tools::OutputFile f(path);
    temp = f.tempPath();
    std::ofstream(temp) << "partial";
  }  // an error: not committed
  EXPECT_FALSE(std::ifstream(path).good());
  EXPECT_FALSE(std::ifstream(temp).good());
  {
    ptz::tools::OutputFile f(path);
    std::ofstream(f.tempPath()) << "whole";
    f.commit();
  }
  std::ifstream in(path);
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()),
            "whole");
  EXPECT_EQ(codeOf([] { ptz::tools::OutputFile f("/nonexistent/out.json"); }), log_exit::kOutput);

  // A folder: new, or an existing one whose other files stay.
  const std::string dir = tempPath("report_dir");
  std::system(("rm -rf '" + dir + "'").c_str());
  {
    ptz::tools::OutputDir d(dir);
    std::ofstream(d.tempPath() + "/a.csv") << "a";
  }
  EXPECT_FALSE(std::ifstream(dir + "/a.csv").good());
  struct stat st {};
  EXPECT_NE(::stat(dir.c_str(), &st), 0);
  for (int run = 0; run < 2; ++run) {
    ptz::tools::OutputDir d(dir);
    std::ofstream(d.tempPath() + "/a.csv") << "run " << run;
    d.commit();
    if (run == 0) std::ofstream(dir + "/mine.txt") << "mine";
  }
  std::ifstream a(dir + "/a.csv");
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>()),
            "run 1");
  EXPECT_TRUE(std::ifstream(dir + "/mine.txt").good());
}
