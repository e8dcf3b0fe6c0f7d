// ptz-log-summary: what an LCM log holds, per channel (messages, rate, size), the stereo frames'
// sequence gaps, each process's last status counters, and the closed-loop numbers of the run
// (tools/logs/run_metrics.hpp). Text on stdout; --json writes the run's summary.json.
#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <map>
#include <string>

#include "common/config.hpp"
#include "tools/logs/log_reader.hpp"
#include "tools/logs/run_metrics.hpp"

namespace {

struct ChannelStats {
  int64_t messages = 0;
  int64_t bytes = 0;
  int64_t first_utime = 0;
  int64_t last_utime = 0;
};

}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz-log-summary",
                "Summarises an LCM log: messages, rates and sizes per channel, "
                "stereo frame gaps, each process's last status counters and "
                "the closed-loop numbers of the run.");
  p.add("log", "", "the LCM log file (required)");
  p.add("json", "", "also write the run's summary as JSON to this file");
  p.add("channel_prefix", "", "prefix of the project's channel names");
  p.add("target_class", "red_ball", "class of the tracked object (for centring and 3D error)");
  p.add("settle_s", 2.0, "s", "centring is measured after this much time from the first frame");
  p.add("csv", "", "also write the heads' true pan/tilt/zoom per frame (SIM_TRUTH) to this CSV");
  try {
    if (!p.parse(argc, argv)) return 0;
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-log-summary: %s\n", e.what());
    return 2;
  }
  const std::string path = p.getString("log");
  if (path.empty()) {
    std::fprintf(stderr, "ptz-log-summary: --log FILE is required\n");
    return 2;
  }
  lcm::LogFile log(path, "r");
  if (!log.good()) {
    std::fprintf(stderr, "ptz-log-summary: cannot read log '%s'\n", path.c_str());
    return 1;
  }
  const std::string prefix = p.getString("channel_prefix");
  ptz::tools::RunMetrics metrics(p.getString("target_class"), p.getDouble("settle_s"));
  std::map<std::string, ChannelStats> channels;
  std::map<std::string, ptzstereo::process_status_t> last_status;
  int64_t frame_gaps = 0, last_seq = -1, undecodable = 0;
  FILE* csv = nullptr;
  if (!p.getString("csv").empty()) {
    csv = std::fopen(p.getString("csv").c_str(), "w");
    if (!csv) {
      std::fprintf(stderr, "ptz-log-summary: cannot write '%s'\n", p.getString("csv").c_str());
      return 1;
    }
    std::fprintf(csv,
                 "t_s,frame_seq,left_pan_rad,left_tilt_rad,left_zoom,right_pan_rad,"
                 "right_tilt_rad,right_zoom\n");
  }
  int64_t first_truth_utime = -1;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    ChannelStats& c = channels[ev->channel];
    if (c.messages == 0) c.first_utime = ev->timestamp;
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
        if (first_truth_utime < 0) first_truth_utime = t.utime;
        std::fprintf(csv, "%.6f,%lld,%.9f,%.9f,%.6f,%.9f,%.9f,%.6f\n",
                     (t.utime - first_truth_utime) * 1e-6, static_cast<long long>(t.frame_seq),
                     t.left_head.pan_rad, t.left_head.tilt_rad, t.left_head.zoom,
                     t.right_head.pan_rad, t.right_head.tilt_rad, t.right_head.zoom);
      }
    } else if (ch == prefix + "OBJECT_POSE") {
      ptzstereo::object_pose_t m;
      if (ptz::tools::decodeEvent(*ev, &m, &undecodable)) metrics.onPose(m);
    } else if (ch == prefix + "PTZ_SETPOINT") {
      ptzstereo::ptz_setpoint_t m;
      if (ptz::tools::decodeEvent(*ev, &m, &undecodable)) metrics.onSetpoint(m);
    } else if (ch.rfind(prefix + "PROCESS_STATUS_", 0) == 0) {
      ptzstereo::process_status_t s;
      if (!ptz::tools::decodeEvent(*ev, &s, &undecodable)) continue;
      last_status[s.process] = s;
      metrics.onStatus(s);
    }
  }
  if (csv) std::fclose(csv);
  std::printf("log %s\n", path.c_str());
  std::printf("%-32s %10s %10s %12s\n", "channel", "messages", "rate Hz", "MB");
  for (const auto& [name, c] : channels) {
    const double span_s = (c.last_utime - c.first_utime) * 1e-6;
    const double rate = span_s > 0 ? (c.messages - 1) / span_s : 0.0;
    std::printf("%-32s %10lld %10.1f %12.2f\n", name.c_str(), static_cast<long long>(c.messages),
                rate, c.bytes / 1e6);
  }
  std::printf("stereo frames missing from the log by sequence number: %lld\n",
              static_cast<long long>(frame_gaps));
  if (undecodable) std::printf("undecodable messages: %lld\n", static_cast<long long>(undecodable));
  for (const auto& [process, s] : last_status) {
    std::printf("%s (last status, uptime %.1f s)%s%s\n", process.c_str(), s.uptime_s,
                s.message.empty() ? "" : ": ", s.message.c_str());
    for (const auto& counter : s.counters) {
      std::printf("  %-36s %lld\n", counter.name.c_str(), static_cast<long long>(counter.value));
    }
  }
  const ptz::tools::RunSummary summary = metrics.summary();
  std::printf("run summary:\n%s", summary.toJson().c_str());
  const std::string json = p.getString("json");
  if (!json.empty()) {
    FILE* f = std::fopen(json.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "ptz-log-summary: cannot write '%s'\n", json.c_str());
      return 1;
    }
    std::fputs(summary.toJson().c_str(), f);
    std::fclose(f);
  }
  return 0;
}
