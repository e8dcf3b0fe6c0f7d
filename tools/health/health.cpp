#include "tools/health/health.hpp"

#include "common/measure.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>
#include <stdexcept>

namespace ptz::health {

using Status = ptzstereo::process_status_t;

const char* verdictName(Verdict v) {
  switch (v) {
    case Verdict::kOk:
      return "OK";
    case Verdict::kWarn:
      return "WARN";
    case Verdict::kError:
      return "ERROR";
    case Verdict::kStale:
      return "STALE";
    case Verdict::kMissing:
      return "MISSING";
  }
  return "?";
}

Board::Board(Options options) : options_(std::move(options)) {}

void Board::onStatus(const Status& msg, int64_t receive_utime) {
  const auto key = std::make_pair(msg.process, msg.hostname);
  auto it = entries_.find(key);
  if (it == entries_.end()) {
    if (entries_.size() >= options_.max_processes) {
      ++ignored_;
      return;
    }
    entries_.emplace(key, Entry{msg, receive_utime, 0});
  } else {
    if (it->second.status.pid != msg.pid) ++it->second.pid_changes;
    it->second.status = msg;
    it->second.receive_utime = receive_utime;
  }
  addClockSample(msg.hostname, msg.utime, receive_utime);
}

void Board::addClockSample(const std::string& hostname, int64_t sent_utime, int64_t receive_utime) {
  // In double: a hostile utime (INT64_MIN, INT64_MAX) cannot overflow, it is merely absurd.
  const double delay_us = static_cast<double>(receive_utime) - static_cast<double>(sent_utime);
  if (!std::isfinite(delay_us) || std::abs(delay_us) > kClockAbsurdS * 1e6) {
    ++clock_ignored_;
    return;
  }
  auto it = clock_samples_.find(hostname);
  if (it == clock_samples_.end()) {
    if (clock_samples_.size() >= options_.max_processes) return;  // entries_ bounds it already
    it = clock_samples_.emplace(hostname, std::deque<ClockSample>{}).first;
  }
  auto& samples = it->second;
  samples.push_back({receive_utime, delay_us});
  const auto too_old = [&](const ClockSample& s) {
    return static_cast<double>(receive_utime) - static_cast<double>(s.receive_utime) >
           kClockWindowS * 1e6;
  };
  while (samples.size() > kClockWindowStatuses || too_old(samples.front())) {
    samples.pop_front();
  }
}

HostClock Board::clockOf(const std::string& hostname,
                         const std::deque<ClockSample>& samples) const {
  HostClock c;
  c.hostname = hostname;
  c.own = !options_.own_hostname.empty() && hostname == options_.own_hostname;
  c.statuses = samples.size();
  if (samples.empty()) return c;
  // receive - send = latency - offset and the one-way latency is >= 0, so the smallest delays are
  // the tightest bound: the estimate is the offset minus a small latency of the window (~0.1-1 ms
  // on a LAN), never more than the true offset. The second smallest, so that one status stamped
  // ahead (a process's clock stepped, a forged one) cannot move the host's estimate alone.
  std::vector<double> delays_us;
  for (const auto& s : samples) delays_us.push_back(s.delay_us);
  const size_t rank = std::min<size_t>(1, delays_us.size() - 1);
  std::nth_element(delays_us.begin(), delays_us.begin() + static_cast<ptrdiff_t>(rank),
                   delays_us.end());
  c.offset_ms = -delays_us[rank] * 1e-3;
  c.too_far = !c.own && c.statuses >= kClockMinStatuses &&
              std::abs(c.offset_ms) > options_.max_clock_offset_ms;
  return c;
}

std::vector<HostClock> Board::clocks() const {
  std::vector<HostClock> out;
  for (const auto& [host, samples] : clock_samples_) out.push_back(clockOf(host, samples));
  return out;
}

namespace {

Verdict fromState(int8_t state) {
  if (state == Status::STATE_OK) return Verdict::kOk;
  if (state == Status::STATE_WARN) return Verdict::kWarn;
  return Verdict::kError;  // ERROR, and any value a process should not send
}

std::vector<InputChannel> inputsOf(const Status& s) {
  std::vector<InputChannel> inputs;
  for (const auto& c : s.channels) {
    if (c.direction != ptzstereo::channel_status_t::DIRECTION_IN) continue;
    InputChannel in;
    in.channel = c.channel;
    in.rate_hz = c.rate_hz;
    in.dropped = c.dropped;
    const std::string prefix = c.channel + ".dropped_";
    for (const auto& counter : s.counters) {
      if (counter.name.size() > prefix.size() &&
          counter.name.compare(0, prefix.size(), prefix) == 0 && counter.value != 0) {
        in.dropped_by_reason[counter.name.substr(prefix.size())] = counter.value;
      }
    }
    inputs.push_back(std::move(in));
  }
  return inputs;
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, std::isfinite(v) ? v : 0.0);
  return buf;
}

}  // namespace

std::vector<ProcessReport> Board::judge(int64_t now_utime) const {
  std::map<std::string, HostClock> clocks;
  for (const auto& [host, samples] : clock_samples_) clocks.emplace(host, clockOf(host, samples));
  std::vector<ProcessReport> reports;
  std::set<std::string> heard;
  for (const auto& [key, e] : entries_) {
    ProcessReport r;
    r.process = e.status.process;
    r.hostname = e.status.hostname;
    r.pid = e.status.pid;
    r.state = e.status.state;
    r.message = e.status.message;
    r.age_s = std::max<int64_t>(0, now_utime - e.receive_utime) * 1e-6;
    r.pid_changes = e.pid_changes;
    r.inputs = inputsOf(e.status);
    r.verdict = r.age_s >= options_.stale_s ? Verdict::kStale : fromState(e.status.state);
    const auto clock = clocks.find(r.hostname);
    if (clock != clocks.end()) {
      r.clock_offset_ms = clock->second.offset_ms;
      if (clock->second.too_far) {
        r.clock_message =
            "clock " + fixed(std::abs(r.clock_offset_ms), 1) + " ms " +
            (r.clock_offset_ms > 0 ? "ahead of" : "behind") + " this host (max_clock_offset_ms " +
            formatNumber(options_.max_clock_offset_ms) + "): sync clocks (chrony/PTP)";
        if (r.verdict == Verdict::kOk) r.verdict = Verdict::kWarn;
      }
    }
    heard.insert(r.process);
    reports.push_back(std::move(r));
  }
  for (const auto& name : options_.expected) {
    if (heard.count(name)) continue;
    ProcessReport r;
    r.process = name;
    reports.push_back(std::move(r));
  }
  std::stable_sort(
      reports.begin(), reports.end(),
      [](const ProcessReport& a, const ProcessReport& b) { return a.process < b.process; });
  return reports;
}

int exitCode(const std::vector<ProcessReport>& reports) {
  if (reports.empty()) return kExitNotOk;  // nothing heard: not a healthy system
  for (const auto& r : reports) {
    if (r.verdict != Verdict::kOk) return kExitNotOk;
  }
  return kExitOk;
}

namespace {
std::string padded(const std::string& s, size_t width) {
  return s.size() >= width ? s + " " : s + std::string(width - s.size(), ' ');
}
}  // namespace

std::string formatLine(const ProcessReport& r) {
  std::string line = padded(printable(r.process, 40), 13);
  if (r.verdict == Verdict::kMissing) {
    return line + padded("-", 13) + padded("-", 8) + padded("MISSING", 8) +
           "no status heard (is it running? same --channel-prefix and LCM URL?)";
  }
  line += padded(printable(r.hostname, 40), 13) + padded(std::to_string(r.pid), 8) +
          padded(verdictName(r.verdict), 8) + padded(fixed(r.age_s, 1) + " s", 8);
  for (const auto& in : r.inputs) {
    line += " " + printable(in.channel, 60) + " " + fixed(in.rate_hz, 1) + " Hz, " +
            std::to_string(in.dropped) + " dropped";
    if (!in.dropped_by_reason.empty()) {
      std::string reasons;
      for (const auto& [reason, n] : in.dropped_by_reason) {
        reasons += (reasons.empty() ? "" : ", ") + std::to_string(n) + " " + printable(reason, 40);
      }
      line += " (" + reasons + ")";
    }
    line += ";";
  }
  if (r.pid_changes > 0) line += " restarted " + std::to_string(r.pid_changes) + "x;";
  if (!r.clock_message.empty()) line += " " + r.clock_message + ";";
  if (r.verdict == Verdict::kStale) {
    line += " no status for " + fixed(r.age_s, 1) + " s (it last said " +
            verdictName(fromState(r.state)) +
            (r.message.empty() ? "" : ": " + printable(r.message)) + ")";
  } else if (!r.message.empty()) {
    line += " " + printable(r.message);
  }
  line.erase(line.find_last_not_of(' ') + 1);
  return line;
}

std::string formatTable(const std::vector<ProcessReport>& reports) {
  std::string out = padded("process", 13) + padded("host", 13) + padded("pid", 8) +
                    padded("state", 8) + padded("age", 8) + " inputs; message\n";
  for (const auto& r : reports) out += formatLine(r) + "\n";
  return out;
}

std::string formatClocks(const std::vector<HostClock>& clocks, double max_clock_offset_ms) {
  const bool other_host =
      std::any_of(clocks.begin(), clocks.end(), [](const HostClock& c) { return !c.own; });
  if (!other_host) return "";  // one host: one clock
  std::string out;
  for (const auto& c : clocks) {
    std::string line = "clock  " + padded(printable(c.hostname, 40), 13);
    if (!std::isfinite(c.offset_ms)) {
      line += "unknown";
    } else {
      const double ms = std::round(c.offset_ms * 10) / 10 + 0.0;  // + 0.0: no "-0.0"
      line += (ms >= 0 ? "+" : "") + fixed(ms, 1) + " ms (" + std::to_string(c.statuses) +
              (c.statuses == 1 ? " status)" : " statuses)");
    }
    if (c.own) line += " this host";
    if (c.too_far) line += " over max_clock_offset_ms " + formatNumber(max_clock_offset_ms);
    out += line + "\n";
  }
  return out;
}

Watchdog::Watchdog(std::vector<std::string> expected, double grace_s, int64_t start_utime)
    : expected_(std::move(expected)),
      grace_us_(static_cast<int64_t>(grace_s * 1e6)),
      start_utime_(start_utime) {
  for (const auto& name : expected_) bad_since_[name] = start_utime_;  // missing from the start
}

std::string Watchdog::update(const std::vector<ProcessReport>& reports, int64_t now_utime) {
  // A process is bad when any line of its name is (several hosts: the worst counts).
  std::map<std::string, bool> bad;
  for (const auto& r : reports) {
    const bool watched = expected_.empty() || std::find(expected_.begin(), expected_.end(),
                                                        r.process) != expected_.end();
    if (!watched) continue;
    const bool is_bad = r.verdict == Verdict::kMissing || r.verdict == Verdict::kStale ||
                        r.verdict == Verdict::kError;
    bad[r.process] = bad[r.process] || is_bad;
  }
  std::string first;
  for (const auto& [name, is_bad] : bad) {
    if (!is_bad) {
      bad_since_.erase(name);
      continue;
    }
    const int64_t since = bad_since_.emplace(name, now_utime).first->second;
    if (first.empty() && now_utime - since >= grace_us_) first = name;
  }
  return first;
}

std::vector<std::string> parseProcessList(const std::string& list) {
  std::vector<std::string> names;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) {
    const auto b = item.find_first_not_of(" \t");
    const auto e = item.find_last_not_of(" \t");
    const std::string name = b == std::string::npos ? "" : item.substr(b, e - b + 1);
    if (name.empty()) throw std::invalid_argument("an empty process name in '" + list + "'");
    for (unsigned char c : name) {
      if (!(std::isalnum(c) || c == '-' || c == '_' || c == '.')) {
        throw std::invalid_argument("process name '" + printable(name) +
                                    "' has a character other than letters, digits, - _ .");
      }
    }
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  }
  return names;
}

std::string formatReport(const Board& board, const std::vector<ProcessReport>& reports,
                         double max_clock_offset_ms) {
  std::string text = formatTable(reports) + formatClocks(board.clocks(), max_clock_offset_ms);
  if (reports.empty()) text += "(no process heard)\n";
  if (board.undecodable() > 0) {
    text += "(" + std::to_string(board.undecodable()) + " status messages did not decode)\n";
  }
  if (board.ignored() > 0) {
    text += "(" + std::to_string(board.ignored()) + " statuses of further processes ignored)\n";
  }
  if (board.clockIgnored() > 0) {
    text += "(" + std::to_string(board.clockIgnored()) +
            " statuses with a send time over a day off: not used for clocks)\n";
  }
  return text;
}

std::string verdictsKey(const std::vector<ProcessReport>& reports) {
  std::string v;
  for (const auto& r : reports) {
    v +=
        r.process + "@" + r.hostname + "=" + verdictName(r.verdict) + std::to_string(r.state) + ";";
  }
  return v;
}

ClockSummary summarizeClocks(const std::vector<HostClock>& clocks) {
  ClockSummary s;
  for (const auto& c : clocks) {
    if (c.own || !std::isfinite(c.offset_ms)) continue;
    s.max_abs_offset_ms = std::max(s.max_abs_offset_ms, std::abs(c.offset_ms));
    s.hosts_too_far += c.too_far;
  }
  return s;
}

}  // namespace ptz::health
