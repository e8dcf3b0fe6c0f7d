// ptz-log-summary: what an LCM log holds, per channel (messages, rate, size), the stereo frames'
// sequence gaps, each process's last status counters, and the closed-loop numbers of the run
// (tools/logs/run_metrics.hpp). Text on stdout; --json writes the run's summary.json. A missing,
// empty or foreign log, or one without the project's channels, has its own exit code
// (tools/logs/log_reader.hpp) and writes nothing; --json and --csv are written under temporary
// names and renamed at the end; a damaged log is summarised as far as it reads, with a warning.
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <array>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "common/measure.hpp"
#include "tools/logs/log_reader.hpp"
#include "tools/logs/run_metrics.hpp"

namespace {

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
// A hostile log could ask for millions of lines.
constexpr size_t kMaxSilencesListed = 1000;

// The heads' true pan, tilt, zoom (left, right) at a frame's capture time.
struct Heads {
  int64_t utime = 0;
  std::array<double, 6> v{};
};

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

// Per frame with truth: the heads' true pan/tilt/zoom, then how the frame was scored (whether
// it had a pose and a target, the true object tracked, ptz-control's state).
void writeCsv(FILE* csv, const std::map<int64_t, Heads>& heads,
              const std::map<int64_t, ptz::tools::FrameScore>& frames) {
  std::fprintf(csv,
               "t_s,frame_seq,left_pan_rad,left_tilt_rad,left_zoom,right_pan_rad,"
               "right_tilt_rad,right_zoom,pose,target,tracked_object,control_state\n");
  int64_t first_utime = 0;
  for (const auto& [seq, t] : heads) {
    first_utime = seq == heads.begin()->first ? t.utime : std::min(first_utime, t.utime);
  }
  for (const auto& [seq, t] : heads) {
    const auto f = frames.find(seq);
    const ptz::tools::FrameScore none;
    const ptz::tools::FrameScore& s = f == frames.end() ? none : f->second;
    std::fprintf(csv, "%.6f,%lld,%.9f,%.9f,%.6f,%.9f,%.9f,%.6f,%d,%d,%s,%s\n",
                 (static_cast<double>(t.utime) - static_cast<double>(first_utime)) * 1e-6,
                 static_cast<long long>(seq), t.v[0], t.v[1], t.v[2], t.v[3], t.v[4], t.v[5],
                 s.pose ? 1 : 0, s.target ? 1 : 0, csvField(s.tracked).c_str(),
                 controlStateName(s.control_state));
  }
}

// The summary; returns the exit code. Throws LogError for a log it cannot use.
int summarise(const ptz::Params& p) {
  const std::string path = p.getString("log");
  if (path.empty()) throw ptz::ConfigError("--log FILE is required");
  ptz::tools::LogReader log(path);
  const std::string prefix = p.getString("channel_prefix");
  ptz::tools::RunMetrics metrics(p.getString("target_class"), p.getDouble("settle_s"));
  std::map<std::string, ChannelStats> channels;
  std::map<std::string, ptzstereo::process_status_t> last_status;
  int64_t frame_gaps = 0, last_seq = -1, undecodable = 0;
  std::unique_ptr<ptz::tools::OutputFile> csv_file, json_file;
  if (!p.getString("json").empty()) {
    json_file = std::make_unique<ptz::tools::OutputFile>(p.getString("json"));
  }
  FILE* csv = nullptr;
  if (!p.getString("csv").empty()) {
    csv_file = std::make_unique<ptz::tools::OutputFile>(p.getString("csv"));
    csv = std::fopen(csv_file->tempPath().c_str(), "w");
    if (!csv) {
      throw ptz::tools::LogError(ptz::tools::log_exit::kOutput,
                                 "cannot write '" + p.getString("csv") + "'");
    }
  }
  // Closed on every way out (the temporary file itself is removed by csv_file).
  const std::unique_ptr<FILE, int (*)(FILE*)> csv_closer(
      csv, [](FILE* f) { return f ? std::fclose(f) : 0; });
  std::map<int64_t, Heads> heads;  // by seq: the CSV is written at the end, in frame order
  const double gaps_over_s = p.getDouble("gaps_over_s");
  std::vector<Silence> silences;
  int64_t silences_not_listed = 0;
  while (const lcm::LogEvent* ev = log.next()) {
    ChannelStats& c = channels[ev->channel];
    if (c.messages == 0) c.first_utime = ev->timestamp;
    const double gap_s =
        c.messages == 0 ? 0 : (static_cast<double>(ev->timestamp) - c.last_utime) * 1e-6;
    c.max_gap_s = std::max(c.max_gap_s, gap_s);
    if (gaps_over_s > 0 && gap_s > gaps_over_s) {
      if (silences.size() < kMaxSilencesListed) {
        silences.push_back({ev->channel, c.last_utime, ev->timestamp});
      } else {
        ++silences_not_listed;
      }
    }
    c.last_utime = ev->timestamp;
    ++c.messages;
    c.bytes += ev->datalen;
    const std::string& ch = ev->channel;
    if (ch == prefix + "STEREO_FRAME") {
      ptzstereo::stereo_frame_t f;
      if (!ptz::tools::decodeEvent(*ev, &f, &undecodable)) continue;
      if (last_seq >= 0 && f.seq > last_seq + 1) frame_gaps += f.seq - last_seq - 1;
      last_seq = f.seq;
      metrics.onFrame(f);
    } else if (ch == prefix + "SIM_TRUTH") {
      ptzstereo::sim_truth_t t;
      if (!ptz::tools::decodeEvent(*ev, &t, &undecodable)) continue;
      metrics.onTruth(t);
      if (csv) {
        heads.emplace(t.frame_seq,
                      Heads{t.utime,
                            {t.left_head.pan_rad, t.left_head.tilt_rad, t.left_head.zoom,
                             t.right_head.pan_rad, t.right_head.tilt_rad, t.right_head.zoom}});
      }
    } else if (ch == prefix + "OBJECT_POSE") {
      ptzstereo::object_pose_t m;
      if (ptz::tools::decodeEvent(*ev, &m, &undecodable)) metrics.onPose(m);
    } else if (ch == prefix + "PTZ_SETPOINT") {
      ptzstereo::ptz_setpoint_t m;
      if (ptz::tools::decodeEvent(*ev, &m, &undecodable)) metrics.onSetpoint(m);
    } else if (ch == prefix + "CONTROL_STATE") {
      ptzstereo::control_state_t m;
      if (ptz::tools::decodeEvent(*ev, &m, &undecodable)) metrics.onControlState(m);
    } else if (ch.rfind(prefix + "PROCESS_STATUS_", 0) == 0) {
      ptzstereo::process_status_t s;
      if (!ptz::tools::decodeEvent(*ev, &s, &undecodable)) continue;
      last_status[s.process] = s;
      metrics.onStatus(s);
    }
  }
  log.requireEvents();
  // A summary of zeros says nothing: the run's own channels must be there.
  log.requireChannels({}, {prefix + "STEREO_FRAME", prefix + "PTZ_STATE", prefix + "PTZ_SETPOINT",
                           prefix + "OBJECT_POSE", prefix + "SIM_TRUTH"});
  if (!log.breaks().empty()) {
    std::fprintf(stderr,
                 "ptz-log-summary: warning: the log is damaged; summarised as far as it "
                 "reads:\n%s",
                 log.describeBreaks().c_str());
  }
  std::printf("log %s\n", path.c_str());
  std::printf("%-32s %10s %10s %12s %10s\n", "channel", "messages", "rate Hz", "MB", "max gap s");
  for (const auto& [name, c] : channels) {
    const double span_s = (c.last_utime - c.first_utime) * 1e-6;
    const double rate = span_s > 0 ? (c.messages - 1) / span_s : 0.0;
    std::printf("%-32s %10lld %10.1f %12.2f %10.3f\n", ptz::printable(name, 100).c_str(),
                static_cast<long long>(c.messages), rate, c.bytes / 1e6, c.max_gap_s);
  }
  for (const auto& g : silences) {
    std::printf("silence %s from %lld to %lld (%.3f s)\n", ptz::printable(g.channel, 100).c_str(),
                static_cast<long long>(g.from_utime), static_cast<long long>(g.to_utime),
                (static_cast<double>(g.to_utime) - g.from_utime) * 1e-6);
  }
  // A channel that fell silent for good: up to the log's last event.
  int64_t log_end_utime = 0;
  for (const auto& [name, c] : channels) log_end_utime = std::max(log_end_utime, c.last_utime);
  for (const auto& [name, c] : channels) {
    const double silent_s = (static_cast<double>(log_end_utime) - c.last_utime) * 1e-6;
    if (gaps_over_s > 0 && silent_s > gaps_over_s) {
      std::printf("silence %s from %lld to the end of the log (%.3f s)\n",
                  ptz::printable(name, 100).c_str(), static_cast<long long>(c.last_utime),
                  silent_s);
    }
  }
  if (silences_not_listed) {
    std::printf("silences not listed (over %zu): %lld\n", kMaxSilencesListed,
                static_cast<long long>(silences_not_listed));
  }
  std::printf("stereo frames missing from the log by sequence number: %lld\n",
              static_cast<long long>(frame_gaps));
  if (undecodable) std::printf("undecodable messages: %lld\n", static_cast<long long>(undecodable));
  if (!log.breaks().empty()) {
    std::printf("damaged: %zu unreadable part(s), %s\n", log.breaks().size(),
                log.truncated() ? "the log is cut off at its end" : "the log's end is whole");
  }
  for (const auto& [process, s] : last_status) {
    std::printf("%s (last status, uptime %.1f s)%s%s\n", ptz::printable(process, 100).c_str(),
                s.uptime_s, s.message.empty() ? "" : ": ", ptz::printable(s.message).c_str());
    // What it sent and received: set against another host's log, what crossed the network.
    for (const auto& c : s.channels) {
      std::printf("  %-3s %-32s %lld messages, %lld dropped\n",
                  c.direction == ptzstereo::channel_status_t::DIRECTION_OUT ? "out" : "in",
                  ptz::printable(c.channel, 100).c_str(), static_cast<long long>(c.messages),
                  static_cast<long long>(c.dropped));
    }
    for (const auto& counter : s.counters) {
      std::printf("  %-36s %lld\n", ptz::printable(counter.name, 100).c_str(),
                  static_cast<long long>(counter.value));
    }
  }
  const ptz::tools::RunSummary summary = metrics.summary();
  std::printf("run summary:\n%s", summary.toJson().c_str());
  if (json_file) {
    FILE* f = std::fopen(json_file->tempPath().c_str(), "w");
    const bool written = f && std::fputs(summary.toJson().c_str(), f) >= 0;
    if (!f || std::fclose(f) != 0 || !written) {
      throw ptz::tools::LogError(ptz::tools::log_exit::kOutput,
                                 "cannot write '" + p.getString("json") + "'");
    }
    json_file->commit();
  }
  if (csv_file) {
    writeCsv(csv, heads, metrics.frames());
    if (std::fflush(csv) != 0) {
      throw ptz::tools::LogError(ptz::tools::log_exit::kOutput,
                                 "cannot write '" + p.getString("csv") + "'");
    }
    csv_file->commit();
  }
  return ptz::tools::log_exit::kOk;
}

}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz-log-summary",
                "Summarises an LCM log: messages, rates and sizes per channel, "
                "stereo frame gaps, each process's last status counters and "
                "the closed-loop numbers of the run.\n" +
                    ptz::tools::logExitCodesHelp(""));
  p.add("log", "", "the LCM log file (required)");
  p.add("json", "", "also write the run's summary as JSON to this file");
  p.add("channel_prefix", "", "prefix of the project's channel names");
  p.add("target_class", "red_ball", "class of the tracked object (for centring and 3D error)");
  p.add("settle_s", 2.0, "s", "centring is measured after this much time from the first frame",
        ptz::Range::atLeast(0));
  p.add("csv", "", "also write the heads' true pan/tilt/zoom per frame (SIM_TRUTH) to this CSV");
  p.add("gaps_over_s", 0.0, "s",
        "also list every silence of a channel longer than this, from and to in log time (us); "
        "0: none",
        ptz::Range::atLeast(0));
  try {
    if (!p.parse(argc, argv)) return ptz::tools::log_exit::kOk;
    return summarise(p);
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-log-summary: %s\n", e.what());
    return ptz::tools::log_exit::kUsage;
  } catch (const ptz::tools::LogError& e) {
    std::fprintf(stderr, "ptz-log-summary: %s\n", e.what());
    return e.exitCode();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptz-log-summary: stopped: %s\n", e.what());
    return ptz::tools::log_exit::kFailed;
  }
}
