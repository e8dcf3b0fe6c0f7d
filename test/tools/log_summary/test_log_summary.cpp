// ptz-log-summary's library on events made here: frame gaps by sequence number, a channel's
// longest gap and its silences over the limit, the printed lines that say so.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "ptzstereo/stereo_frame_t.hpp"
#include "tools/log_summary/log_summary.hpp"

namespace {

struct Event {
  std::string channel;
  std::vector<uint8_t> bytes;
  int64_t utime;
};

Event frameEvent(int64_t seq, int64_t utime) {
  ptzstereo::stereo_frame_t m{};
  m.seq = seq;
  m.utime = utime;
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return {"STEREO_FRAME", bytes, utime};
}

void add(ptz::tools::LogSummary* s, Event& e) {
  lcm::LogEvent ev{};
  ev.timestamp = e.utime;
  ev.channel = e.channel;
  ev.datalen = static_cast<int32_t>(e.bytes.size());
  ev.data = e.bytes.data();
  s->add(ev);
}

}  // namespace

TEST(LogSummary, CountsFrameGapsAndListsSilencesOverTheLimit) {
  ptz::tools::SummaryOptions o;
  o.gaps_over_s = 0.5;
  ptz::tools::LogSummary summary(o);
  // Frames 1, 2, 5, 6 (3 and 4 missing), a second of silence between 2 and 5.
  std::vector<Event> events = {frameEvent(1, 1'000'000),
                               frameEvent(2, 1'100'000),
                               frameEvent(5, 2'100'000),
                               frameEvent(6, 2'200'000),
                               {"GARBAGE", {1, 2, 3}, 2'300'000}};
  for (auto& e : events) add(&summary, e);
  EXPECT_EQ(summary.frameGaps(), 2);
  EXPECT_EQ(summary.undecodable(), 0);
  char* text = nullptr;
  size_t size = 0;
  FILE* out = open_memstream(&text, &size);
  summary.print(out, "test.lcmlog", /*breaks=*/1, /*truncated=*/true);
  std::fclose(out);
  const std::string printed(text, size);
  free(text);
  EXPECT_NE(printed.find("silence STEREO_FRAME from 1100000 to 2100000 (1.000 s)"),
            std::string::npos)
      << printed;
  EXPECT_NE(printed.find("stereo frames missing from the log by sequence number: 2"),
            std::string::npos);
  EXPECT_NE(printed.find("GARBAGE"), std::string::npos);
  EXPECT_NE(printed.find("damaged: 1 unreadable part(s), the log is cut off at its end"),
            std::string::npos);
}
