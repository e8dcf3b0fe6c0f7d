// ptz-health's judgement, without LCM: the latest PROCESS_STATUS of each process, and whether
// each is OK, WARN, ERROR (as it says), STALE (silent too long) or MISSING (expected, never
// heard); one line per process and one exit code for scripts and service managers.
#pragma once

#include <cstdint>
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
};

struct Options {
  std::vector<std::string> expected;  // process names (e.g. ptz-sim); missing ones are named
  double stale_s = 3.0;               // no status for this long: STALE
  size_t max_processes = 1000;        // statuses of more distinct names are ignored (hostile)
};

// Holds the latest status of each process (by name and host) and judges them.
class Board {
 public:
  explicit Board(Options options);

  // A status received at receive_utime (the listener's wall clock: ages never depend on the
  // sender's clock). A new pid for a known process counts a restart.
  void onStatus(const ptzstereo::process_status_t& msg, int64_t receive_utime);
  // A status that did not decode (counted by the subscription, reported here).
  void setUndecodable(int64_t n) { undecodable_ = n; }
  int64_t undecodable() const { return undecodable_; }
  int64_t ignored() const { return ignored_; }

  // Every process heard plus every expected one never heard, in name order.
  std::vector<ProcessReport> judge(int64_t now_utime) const;

 private:
  struct Entry {
    ptzstereo::process_status_t status;
    int64_t receive_utime;
    int pid_changes;
  };
  Options options_;
  std::map<std::pair<std::string, std::string>, Entry> entries_;  // (process, host)
  int64_t undecodable_ = 0;
  int64_t ignored_ = 0;
};

// kExitOk when every report is OK, else kExitNotOk (also when there is none: nothing heard).
int exitCode(const std::vector<ProcessReport>& reports);

// One line: NAME HOST PID VERDICT AGE, then each input's rate and drops, then the message.
std::string formatLine(const ProcessReport& r);
// A header line and one line per report.
std::string formatTable(const std::vector<ProcessReport>& reports);

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

// Text from another process made printable: control characters escaped, at most max_chars.
std::string printable(const std::string& text, size_t max_chars = 200);

}  // namespace ptz::health
