// ptz-log-summary: what an LCM log holds, per channel (messages, rate, size), the stereo frames'
// sequence gaps, and the last PROCESS_STATUS counters of every process. Text, or JSON.
#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <map>
#include <string>

#include "ptz/config.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace {

struct ChannelStats {
  int64_t messages = 0;
  int64_t bytes = 0;
  int64_t first_utime = 0;
  int64_t last_utime = 0;
};

std::string jsonEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz-log-summary",
                "Summarises an LCM log: messages, rates and sizes per channel, "
                "stereo frame gaps, and each process's last status counters.");
  p.add("log", "", "the LCM log file (required)");
  p.add("json", "", "also write the summary as JSON to this file");
  p.add("channel_prefix", "", "prefix of the project's channel names");
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
  const std::string frame_channel = prefix + "STEREO_FRAME";
  const std::string status_prefix = prefix + "PROCESS_STATUS_";
  std::map<std::string, ChannelStats> channels;
  std::map<std::string, ptzstereo::process_status_t> last_status;
  int64_t frames = 0, frame_gaps = 0, last_seq = -1, undecodable = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    ChannelStats& c = channels[ev->channel];
    if (c.messages == 0) c.first_utime = ev->timestamp;
    c.last_utime = ev->timestamp;
    ++c.messages;
    c.bytes += ev->datalen;
    if (ev->channel == frame_channel) {
      ptzstereo::stereo_frame_t f;
      if (f.decode(ev->data, 0, ev->datalen) < 0) {
        ++undecodable;
        continue;
      }
      ++frames;
      if (last_seq >= 0 && f.seq > last_seq + 1) frame_gaps += f.seq - last_seq - 1;
      last_seq = f.seq;
    } else if (ev->channel.rfind(status_prefix, 0) == 0) {
      ptzstereo::process_status_t s;
      if (s.decode(ev->data, 0, ev->datalen) < 0) {
        ++undecodable;
        continue;
      }
      last_status[s.process] = s;
    }
  }
  std::printf("log %s\n", path.c_str());
  std::printf("%-32s %10s %10s %12s\n", "channel", "messages", "rate Hz", "MB");
  for (const auto& [name, c] : channels) {
    const double span_s = (c.last_utime - c.first_utime) * 1e-6;
    const double rate = span_s > 0 ? (c.messages - 1) / span_s : 0.0;
    std::printf("%-32s %10lld %10.1f %12.2f\n", name.c_str(), static_cast<long long>(c.messages),
                rate, c.bytes / 1e6);
  }
  std::printf("stereo frames: %lld logged, %lld missing by sequence number\n",
              static_cast<long long>(frames), static_cast<long long>(frame_gaps));
  if (undecodable) std::printf("undecodable messages: %lld\n", static_cast<long long>(undecodable));
  for (const auto& [process, s] : last_status) {
    std::printf("%s (last status, uptime %.1f s)%s%s\n", process.c_str(), s.uptime_s,
                s.message.empty() ? "" : ": ", s.message.c_str());
    for (const auto& counter : s.counters) {
      std::printf("  %-36s %lld\n", counter.name.c_str(), static_cast<long long>(counter.value));
    }
  }
  const std::string json = p.getString("json");
  if (!json.empty()) {
    FILE* f = std::fopen(json.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "ptz-log-summary: cannot write '%s'\n", json.c_str());
      return 1;
    }
    std::fprintf(f,
                 "{\n  \"log\": \"%s\",\n  \"frames_logged\": %lld,\n  \"frames_missing\": %lld,\n",
                 jsonEscape(path).c_str(), static_cast<long long>(frames),
                 static_cast<long long>(frame_gaps));
    std::fprintf(f, "  \"channels\": {");
    bool first = true;
    for (const auto& [name, c] : channels) {
      std::fprintf(f, "%s\n    \"%s\": {\"messages\": %lld, \"bytes\": %lld}", first ? "" : ",",
                   jsonEscape(name).c_str(), static_cast<long long>(c.messages),
                   static_cast<long long>(c.bytes));
      first = false;
    }
    std::fprintf(f, "\n  },\n  \"counters\": {");
    first = true;
    for (const auto& [process, s] : last_status) {
      for (const auto& counter : s.counters) {
        std::fprintf(f, "%s\n    \"%s.%s\": %lld", first ? "" : ",", jsonEscape(process).c_str(),
                     jsonEscape(counter.name).c_str(), static_cast<long long>(counter.value));
        first = false;
      }
    }
    std::fprintf(f, "\n  }\n}\n");
    std::fclose(f);
  }
  return 0;
}
