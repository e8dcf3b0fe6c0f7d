#include "tools/log_summary/log_summary.hpp"

#include <algorithm>

#include "common/measure.hpp"
#include "tools/logs/log_reader.hpp"

namespace ptz::tools {
namespace {

// A hostile log could ask for millions of lines.
constexpr size_t kMaxSilencesListed = 1000;

// A name from the log as one CSV field: quoted when it holds a separator, quote or line break.
std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

const char* controlStateName(int state) {
  static const char* const kNames[] = {"tracking", "coasting", "searching", "holding", "homing"};
  return state >= 0 && state < 5 ? kNames[state] : "";
}

}  // namespace

LogSummary::LogSummary(const SummaryOptions& options)
    : options_(options), metrics_(options.target_class, options.settle_s) {}

void LogSummary::add(const lcm::LogEvent& ev) {
  ChannelStats& c = channels_[ev.channel];
  if (c.messages == 0) c.first_utime = ev.timestamp;
  const double gap_s =
      c.messages == 0 ? 0 : (static_cast<double>(ev.timestamp) - c.last_utime) * 1e-6;
  c.max_gap_s = std::max(c.max_gap_s, gap_s);
  if (options_.gaps_over_s > 0 && gap_s > options_.gaps_over_s) {
    if (silences_.size() < kMaxSilencesListed) {
      silences_.push_back({ev.channel, c.last_utime, ev.timestamp});
    } else {
      ++silences_not_listed_;
    }
  }
  c.last_utime = ev.timestamp;
  ++c.messages;
  c.bytes += ev.datalen;
  decodeProjectMessage(ev);
}

void LogSummary::decodeProjectMessage(const lcm::LogEvent& ev) {
  const std::string& ch = ev.channel;
  const std::string& prefix = options_.channel_prefix;
  if (ch == prefix + "STEREO_FRAME") {
    ptzstereo::stereo_frame_t f;
    if (!decodeEvent(ev, &f, &undecodable_)) return;
    if (last_seq_ >= 0 && f.seq > last_seq_ + 1) frame_gaps_ += f.seq - last_seq_ - 1;
    last_seq_ = f.seq;
    metrics_.onFrame(f);
  } else if (ch == prefix + "SIM_TRUTH") {
    ptzstereo::sim_truth_t t;
    if (!decodeEvent(ev, &t, &undecodable_)) return;
    metrics_.onTruth(t);
    if (options_.keep_heads) {
      heads_.emplace(t.frame_seq,
                     Heads{t.utime,
                           {t.left_head.pan_rad, t.left_head.tilt_rad, t.left_head.zoom,
                            t.right_head.pan_rad, t.right_head.tilt_rad, t.right_head.zoom}});
    }
  } else if (ch == prefix + "OBJECT_POSE") {
    ptzstereo::object_pose_t m;
    if (decodeEvent(ev, &m, &undecodable_)) metrics_.onPose(m);
  } else if (ch == prefix + "PTZ_SETPOINT") {
    ptzstereo::ptz_setpoint_t m;
    if (decodeEvent(ev, &m, &undecodable_)) metrics_.onSetpoint(m);
  } else if (ch == prefix + "CONTROL_STATE") {
    ptzstereo::control_state_t m;
    if (decodeEvent(ev, &m, &undecodable_)) metrics_.onControlState(m);
  } else if (ch.rfind(prefix + "PROCESS_STATUS_", 0) == 0) {
    ptzstereo::process_status_t s;
    if (!decodeEvent(ev, &s, &undecodable_)) return;
    last_status_[s.process] = s;
    metrics_.onStatus(s);
  }
}

void LogSummary::print(FILE* out, const std::string& path, size_t breaks, bool truncated) const {
  std::fprintf(out, "log %s\n", path.c_str());
  std::fprintf(out, "%-32s %10s %10s %12s %10s\n", "channel", "messages", "rate Hz", "MB",
               "max gap s");
  for (const auto& [name, c] : channels_) {
    const double span_s = (c.last_utime - c.first_utime) * 1e-6;
    const double rate = span_s > 0 ? (c.messages - 1) / span_s : 0.0;
    std::fprintf(out, "%-32s %10lld %10.1f %12.2f %10.3f\n", printable(name, 100).c_str(),
                 static_cast<long long>(c.messages), rate, c.bytes / 1e6, c.max_gap_s);
  }
  for (const auto& g : silences_) {
    std::fprintf(out, "silence %s from %lld to %lld (%.3f s)\n", printable(g.channel, 100).c_str(),
                 static_cast<long long>(g.from_utime), static_cast<long long>(g.to_utime),
                 (static_cast<double>(g.to_utime) - g.from_utime) * 1e-6);
  }
  // A channel that fell silent for good: up to the log's last event.
  int64_t log_end_utime = 0;
  for (const auto& [name, c] : channels_) log_end_utime = std::max(log_end_utime, c.last_utime);
  for (const auto& [name, c] : channels_) {
    const double silent_s = (static_cast<double>(log_end_utime) - c.last_utime) * 1e-6;
    if (options_.gaps_over_s > 0 && silent_s > options_.gaps_over_s) {
      std::fprintf(out, "silence %s from %lld to the end of the log (%.3f s)\n",
                   printable(name, 100).c_str(), static_cast<long long>(c.last_utime), silent_s);
    }
  }
  if (silences_not_listed_) {
    std::fprintf(out, "silences not listed (over %zu): %lld\n", kMaxSilencesListed,
                 static_cast<long long>(silences_not_listed_));
  }
  std::fprintf(out, "stereo frames missing from the log by sequence number: %lld\n",
               static_cast<long long>(frame_gaps_));
  if (undecodable_) {
    std::fprintf(out, "undecodable messages: %lld\n", static_cast<long long>(undecodable_));
  }
  if (breaks > 0) {
    std::fprintf(out, "damaged: %zu unreadable part(s), %s\n", breaks,
                 truncated ? "the log is cut off at its end" : "the log's end is whole");
  }
  printStatuses(out);
  std::fprintf(out, "run summary:\n%s", runSummary().toJson().c_str());
}

void LogSummary::printStatuses(FILE* out) const {
  for (const auto& [process, s] : last_status_) {
    std::fprintf(out, "%s (last status, uptime %.1f s)%s%s\n", printable(process, 100).c_str(),
                 s.uptime_s, s.message.empty() ? "" : ": ", printable(s.message).c_str());
    // What it sent and received: set against another host's log, what crossed the network.
    for (const auto& c : s.channels) {
      std::fprintf(out, "  %-3s %-32s %lld messages, %lld dropped\n",
                   c.direction == ptzstereo::channel_status_t::DIRECTION_OUT ? "out" : "in",
                   printable(c.channel, 100).c_str(), static_cast<long long>(c.messages),
                   static_cast<long long>(c.dropped));
    }
    for (const auto& counter : s.counters) {
      std::fprintf(out, "  %-36s %lld\n", printable(counter.name, 100).c_str(),
                   static_cast<long long>(counter.value));
    }
  }
}

void LogSummary::writeCsv(FILE* csv) const {
  std::fprintf(csv,
               "t_s,frame_seq,left_pan_rad,left_tilt_rad,left_zoom,right_pan_rad,"
               "right_tilt_rad,right_zoom,pose,target,tracked_object,control_state\n");
  int64_t first_utime = 0;
  for (const auto& [seq, t] : heads_) {
    first_utime = seq == heads_.begin()->first ? t.utime : std::min(first_utime, t.utime);
  }
  const auto frames = metrics_.frames();
  for (const auto& [seq, t] : heads_) {
    const auto f = frames.find(seq);
    const FrameScore none;
    const FrameScore& s = f == frames.end() ? none : f->second;
    std::fprintf(csv, "%.6f,%lld,%.9f,%.9f,%.6f,%.9f,%.9f,%.6f,%d,%d,%s,%s\n",
                 (static_cast<double>(t.utime) - static_cast<double>(first_utime)) * 1e-6,
                 static_cast<long long>(seq), t.v[0], t.v[1], t.v[2], t.v[3], t.v[4], t.v[5],
                 s.pose ? 1 : 0, s.target ? 1 : 0, csvField(s.tracked).c_str(),
                 controlStateName(s.control_state));
  }
}

}  // namespace ptz::tools
