// What ptz-log-summary makes of a log, event by event (no files opened here): per channel
// messages, bytes, rate and the longest gap, silences longer than a limit, the stereo frames'
// sequence gaps, each process's last status, the run's numbers (tools/logs/run_metrics.hpp) and
// the heads' true pan/tilt/zoom per frame for the CSV.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <array>
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "ptzstereo/process_status_t.hpp"
#include "tools/logs/run_metrics.hpp"

namespace ptz::tools {

struct SummaryOptions {
  std::string channel_prefix;
  std::string target_class = "red_ball";
  double settle_s = 2.0;
  double gaps_over_s = 0;   // list silences longer than this; 0: none
  bool keep_heads = false;  // for writeCsv
};

class LogSummary {
 public:
  explicit LogSummary(const SummaryOptions& options);

  void add(const lcm::LogEvent& ev);
  // The text of the summary; breaks: unreadable parts of the log, truncated: cut off at its end.
  void print(FILE* out, const std::string& path, size_t breaks, bool truncated) const;
  // Per frame with truth: the heads' true pan/tilt/zoom, then how the frame was scored.
  void writeCsv(FILE* csv) const;
  RunSummary runSummary() const { return metrics_.summary(); }
  int64_t frameGaps() const { return frame_gaps_; }
  int64_t undecodable() const { return undecodable_; }

 private:
  struct ChannelStats {
    int64_t messages = 0;
    int64_t bytes = 0;
    int64_t first_utime = 0;
    int64_t last_utime = 0;
    double max_gap_s = 0;  // the longest time between two of its messages
  };
  // A time a channel was silent: from one message to the next, log (receive) times.
  struct Silence {
    std::string channel;
    int64_t from_utime, to_utime;
  };
  // The heads' true pan, tilt, zoom (left, right) at a frame's capture time.
  struct Heads {
    int64_t utime = 0;
    std::array<double, 6> v{};
  };
  void decodeProjectMessage(const lcm::LogEvent& ev);
  void printStatuses(FILE* out) const;

  SummaryOptions options_;
  RunMetrics metrics_;
  std::map<std::string, ChannelStats> channels_;
  std::map<std::string, ptzstereo::process_status_t> last_status_;
  std::map<int64_t, Heads> heads_;  // by seq: the CSV is written at the end, in frame order
  std::vector<Silence> silences_;
  int64_t silences_not_listed_ = 0;
  int64_t frame_gaps_ = 0, last_seq_ = -1, undecodable_ = 0;
};

}  // namespace ptz::tools
