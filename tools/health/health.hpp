// ptz-health's judgement, without LCM: the latest PROCESS_STATUS of each process, and whether
// each is OK, WARN, ERROR (as it says), STALE (silent too long) or MISSING (expected, never
// heard); one line per process and one exit code for scripts and service managers.
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "ptzstereo/process_status_t.hpp"

namespace ptz::health {

enum class Verdict { kOk, kWarn, kError, kStale, kMissing };
const char* verdictName(Verdict v);

// Exit codes of ptz-health, one meaning each.
constexpr int kExitOk = 0;        // every process heard or expected is OK
constexpr int kExitNotOk = 1;     // one or more not OK, stale or missing; or none heard
constexpr int kExitBadFlags = 2;  // a flag or the config file refused
constexpr int kExitNoListen = 3;  // LCM would not open or failed while listening
constexpr int kExitInternal = 4;  // an unexpected error of ptz-health itself

struct InputChannel {
  std::string channel;
  double rate_hz = 0;
  int64_t dropped = 0;
  std::map<std::string, int64_t> dropped_by_reason;  // from counters CHANNEL.dropped_REASON
};

struct ProcessReport {
  std::string process;
  std::string hostname;
  int32_t pid = 0;
  Verdict verdict = Verdict::kMissing;
  int8_t state = ptzstereo::process_status_t::STATE_OK;  // as the process said
  std::string message;                                   // as the process said
  double age_s = -1;                                     // since its last status; -1: none
  int pid_changes = 0;                                   // restarts seen while listening
  std::vector<InputChannel> inputs;
  double clock_offset_ms = NAN;  // its host's clock minus the listener's; NaN: unknown
  std::string clock_message;     // why its host's clock makes it WARN, or ""
};

// The clock of one sending host as estimated from its statuses' times.
struct HostClock {
  std::string hostname;
  double offset_ms = NAN;  // its clock minus the listener's; NaN: no usable status
  size_t statuses = 0;     // in the window the estimate is taken over
  bool own = false;        // the listener's host: never judged (its offset is ~latency)
  bool too_far = false;    // |offset_ms| > max_clock_offset_ms, from kClockMinStatuses on
};

// The clock-offset window per host: the last statuses, and none older than the newest by more
// than kClockWindowS (so a clock step is followed). An offset beyond kClockAbsurdS is hostile or
// broken and is not used.
constexpr size_t kClockWindowStatuses = 30;
constexpr double kClockWindowS = 60.0;
constexpr double kClockAbsurdS = 86400.0;
// A host is judged from its second status on: one late delivery (the listener starting up) alone
// would look like a clock behind.
constexpr size_t kClockMinStatuses = 2;

struct Options {
  std::vector<std::string> expected;  // process names (e.g. ptz-sim); missing ones are named
  double stale_s = 3.0;               // no status for this long: STALE
  size_t max_processes = 1000;        // statuses of more distinct names are ignored (hostile)
  double max_clock_offset_ms = 5.0;   // another host's clock further off than this: WARN
  std::string own_hostname{};         // the listener's host: its clock is never judged
};

// Holds the latest status of each process (by name and host) and judges them.
class Board {
 public:
  explicit Board(Options options);

  // A status received at receive_utime (the listener's wall clock: ages never depend on the
  // sender's clock). A new pid for a known process counts a restart. Its utime against
  // receive_utime feeds the clock-offset estimate of its host.
  void onStatus(const ptzstereo::process_status_t& msg, int64_t receive_utime);
  // A status that did not decode (counted by the subscription, reported here).
  void setUndecodable(int64_t n) { undecodable_ = n; }
  int64_t undecodable() const { return undecodable_; }
  int64_t ignored() const { return ignored_; }
  // Statuses whose send time was absurd (beyond kClockAbsurdS off): not used for clocks.
  int64_t clockIgnored() const { return clock_ignored_; }

  // The clock of every host heard, in host name order.
  std::vector<HostClock> clocks() const;

  // Every process heard plus every expected one never heard, in name order.
  std::vector<ProcessReport> judge(int64_t now_utime) const;

 private:
  struct Entry {
    ptzstereo::process_status_t status;
    int64_t receive_utime;
    int pid_changes;
  };
  struct ClockSample {
    int64_t receive_utime;
    double delay_us;  // receive_utime - the sender's utime: latency minus the clock offset
  };
  void addClockSample(const std::string& hostname, int64_t sent_utime, int64_t receive_utime);
  HostClock clockOf(const std::string& hostname, const std::deque<ClockSample>& samples) const;

  Options options_;
  std::map<std::pair<std::string, std::string>, Entry> entries_;  // (process, host)
  std::map<std::string, std::deque<ClockSample>> clock_samples_;  // by sender's host
  int64_t undecodable_ = 0;
  int64_t ignored_ = 0;
  int64_t clock_ignored_ = 0;
};

// kExitOk when every report is OK, else kExitNotOk (also when there is none: nothing heard).
int exitCode(const std::vector<ProcessReport>& reports);

// One line: NAME HOST PID VERDICT AGE, then each input's rate and drops, then the message.
std::string formatLine(const ProcessReport& r);
// A header line and one line per report.
std::string formatTable(const std::vector<ProcessReport>& reports);
// One line per host: "clock  host-a       +0.4 ms (12 statuses)", and what is wrong with it;
// nothing when every status came from the listener's own host.
std::string formatClocks(const std::vector<HostClock>& clocks, double max_clock_offset_ms);

// What is printed: the table, the clocks, and notes of what was not heard or not used.
std::string formatReport(const Board& board, const std::vector<ProcessReport>& reports,
                         double max_clock_offset_ms);
// What --changes_only compares: each process's verdict and state.
std::string verdictsKey(const std::vector<ProcessReport>& reports);
// The largest clock offset of another host and how many hosts are too far (the status's
// counters: not one per host, whose names are the senders').
struct ClockSummary {
  double max_abs_offset_ms = 0;
  int hosts_too_far = 0;
};
ClockSummary summarizeClocks(const std::vector<HostClock>& clocks);

// The watchdog of --watch: the first process (of the expected ones, or of every one heard when
// none is expected) that has been MISSING, STALE or ERROR without a break for grace_s.
class Watchdog {
 public:
  Watchdog(std::vector<std::string> expected, double grace_s, int64_t start_utime);
  // Returns the name of a process bad for grace_s, or "" while none is.
  std::string update(const std::vector<ProcessReport>& reports, int64_t now_utime);

 private:
  std::vector<std::string> expected_;
  int64_t grace_us_;
  int64_t start_utime_;
  std::map<std::string, int64_t> bad_since_;
};

// Process names from "a,b,c" (blanks around names ignored); throws std::invalid_argument for an
// empty name or one with characters a process name cannot have.
std::vector<std::string> parseProcessList(const std::string& list);

}  // namespace ptz::health
