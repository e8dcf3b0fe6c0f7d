// ptz-health: listens to every PROCESS_STATUS_* and prints one line per process; its exit code
// says whether all are OK (health.hpp lists the codes). One-shot (listen, print, exit) or --watch
// (a table every second; as a watchdog it exits 1 once a watched process has been missing, stale
// or ERROR for grace_s, and in watch mode it is itself a process with a status and sd_notify).
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include "common/transport/channel_regex.hpp"
#include "common/transport/transport.hpp"
#include "tools/health/health.hpp"

namespace ptz::health {
namespace {

void declare(Params& p) {
  addTransportParams(p);
  p.add("expect", "", "comma-separated processes that must be there, e.g. ptz-sim,ptz-detect");
  p.add("stale_s", 3.0, "s", "a process without a status for this long is STALE", Range::above(0));
  p.add("listen_s", 2.5, "s", "one-shot: listen this long, then print and exit",
        Range::above(0).andAtMost(3600));
  p.add("watch", false, "print a table every second until SIGINT/SIGTERM (a watchdog)");
  p.add("grace_s", 5.0, "s",
        "watch: exit 1 once a watched process has been missing, stale or ERROR this long",
        Range::atLeast(0));
  p.add("changes_only", false,
        "watch: print the table only when a process appears, goes or changes state (journals)");
  p.add("max_clock_offset_ms", 5.0, "ms",
        "another host whose clock is further off than this (estimated from status times) makes "
        "its processes WARN",
        Range::above(0));
}

// The host ptz-health runs on: its processes' clocks are this clock.
std::string ownHostname() {
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  return host;
}

class HealthNode {
 public:
  HealthNode(const Params& p, lcm::LCM* lcm, Options options)
      : lcm_(lcm),
        status_(lcm, p, "ptz-health"),
        expected_(options.expected),
        hostname_(options.own_hostname),
        max_clock_offset_ms_(options.max_clock_offset_ms),
        board_(std::move(options)),
        listen_s_(p.getDouble("listen_s")),
        grace_s_(p.getDouble("grace_s")),
        changes_only_(p.getBool("changes_only")) {
    const std::string pattern = channelsStartingWith(channel(p, channels::kProcessStatusPrefix));
    statuses_ = std::make_unique<SafeSubscription<ptzstereo::process_status_t>>(
        *lcm_, pattern, status_,
        [this](const std::string&, const ptzstereo::process_status_t& m) { onStatus(m); });
  }

  int runOnce() {
    const int64_t end = wallUtime() + static_cast<int64_t>(listen_s_ * 1e6);
    while (!StopFlag::stopRequested()) {
      const int64_t left_ms = (end - wallUtime()) / 1000;
      if (left_ms <= 0) break;
      if (!handle(static_cast<int>(std::min<int64_t>(left_ms, 100)))) return cannotListen();
    }
    const auto reports = judge();
    print(reports);
    return exitCode(reports);
  }

  int runWatch() {
    Watchdog watchdog(expected_, grace_s_, wallUtime());
    status_.publishNow();  // up and listening (READY=1 under systemd)
    int64_t next_print = wallUtime() + 1'000'000;
    while (!StopFlag::stopRequested()) {
      if (!handle(100)) return cannotListen();
      status_.maybePublish();
      const int64_t now = wallUtime();
      if (now < next_print) continue;
      next_print += 1'000'000;
      if (next_print < now) next_print = now + 1'000'000;  // suspended, or a clock step
      const auto reports = judge();
      const std::string now_verdicts = verdictsKey(reports);
      if (!changes_only_ || now_verdicts != printed_verdicts_) print(reports);
      printed_verdicts_ = now_verdicts;
      int not_ok = 0;
      for (const auto& r : reports) not_ok += r.verdict != Verdict::kOk;
      status_.setCounter("processes_not_ok", not_ok);
      setClockCounters();
      const std::string bad = watchdog.update(reports, now);
      if (!bad.empty()) {
        if (changes_only_) print(reports);
        std::fprintf(stderr, "ptz-health: %s has been missing, stale or ERROR for %g s or more\n",
                     printable(bad).c_str(), grace_s_);
        status_.publishNow();
        return kExitNotOk;
      }
    }
    status_.publishNow();
    return kExitOk;
  }

 private:
  // False when LCM failed; a signal (SIGTERM, SIGINT: the stop) interrupting the wait is none.
  bool handle(int timeout_ms) {
    if (lcm_->handleTimeout(timeout_ms) >= 0) return true;
    return errno == EINTR || StopFlag::stopRequested();
  }

  void onStatus(const ptzstereo::process_status_t& m) {
    if (m.pid == getpid() && m.hostname == hostname_) return;  // its own status (watch mode)
    status_.increment("statuses_received");
    board_.onStatus(m, wallUtime());
  }

  std::vector<ProcessReport> judge() {
    board_.setUndecodable(status_.counter("dropped_undecodable"));
    return board_.judge(wallUtime());
  }

  void setClockCounters() {
    const ClockSummary c = summarizeClocks(board_.clocks());
    status_.setCounter("clock_offset_us_max_abs", std::llround(c.max_abs_offset_ms * 1e3));
    status_.setCounter("clock_hosts_too_far", c.hosts_too_far);
  }

  void print(const std::vector<ProcessReport>& reports) {
    std::fputs(formatReport(board_, reports, max_clock_offset_ms_).c_str(), stdout);
    std::fflush(stdout);
  }

  int cannotListen() {
    std::fprintf(stderr, "ptz-health: LCM failed while listening\n");
    return kExitNoListen;
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  std::vector<std::string> expected_;
  std::string hostname_;
  double max_clock_offset_ms_;
  Board board_;
  double listen_s_;
  double grace_s_;
  bool changes_only_;
  std::string printed_verdicts_;
  std::unique_ptr<SafeSubscription<ptzstereo::process_status_t>> statuses_;
};

}  // namespace
}  // namespace ptz::health

int main(int argc, char** argv) {
  using namespace ptz::health;
  ptz::Params p("ptz-health",
                "Prints the health of every process from its PROCESS_STATUS; exit 0 all OK, 1 "
                "one or more not OK, stale or missing (or none heard), 2 bad flags, 3 could not "
                "listen, 4 internal error.");
  declare(p);
  Options options;
  try {
    if (!p.parse(argc, argv)) return kExitOk;
    options.expected = parseProcessList(p.getString("expect"));
    options.stale_s = p.getDouble("stale_s");
    options.max_clock_offset_ms = p.getDouble("max_clock_offset_ms");
    options.own_hostname = ownHostname();
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-health: %s\n", e.what());
    return kExitBadFlags;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "ptz-health: %s: %s\n", p.sourceOf("expect").c_str(), e.what());
    return kExitBadFlags;
  }
  try {
    const std::string url = ptz::lcmUrl(p);
    lcm::LCM lcm(url);
    if (!lcm.good()) {
      std::fprintf(stderr,
                   "ptz-health: cannot open LCM at '%s' (multicast route? scripts/check-network "
                   "says)\n",
                   url.c_str());
      return kExitNoListen;
    }
    ptz::StopFlag::install();
    HealthNode node(p, &lcm, std::move(options));
    return p.getBool("watch") ? node.runWatch() : node.runOnce();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptz-health: stopped: %s\n", e.what());
    return kExitInternal;
  }
}
