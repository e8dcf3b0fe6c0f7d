// ptz-log-summary: what an LCM log holds, per channel (messages, rate, size), the stereo frames'
// sequence gaps, each process's last status counters, and the closed-loop numbers of the run
// (tools/logs/run_metrics.hpp). Text on stdout; --json writes the run's summary.json. A missing,
// empty or foreign log, or one without the project's channels, has its own exit code
// (tools/logs/log_reader.hpp) and writes nothing; --json and --csv are written under temporary
// names and renamed at the end; a damaged log is summarised as far as it reads, with a warning.
#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <memory>
#include <string>

#include "common/config.hpp"
#include "tools/log_summary/log_summary.hpp"
#include "tools/logs/log_reader.hpp"

namespace {

using ptz::tools::LogError;
namespace lx = ptz::tools::log_exit;

// The summary; returns the exit code. Throws LogError for a log it cannot use.
int summarise(const ptz::Params& p) {
  const std::string path = p.getString("log");
  if (path.empty()) throw ptz::ConfigError("--log FILE is required");
  ptz::tools::LogReader log(path);
  const std::string prefix = p.getString("channel_prefix");
  std::unique_ptr<ptz::tools::OutputFile> csv_file, json_file;
  if (!p.getString("json").empty()) {
    json_file = std::make_unique<ptz::tools::OutputFile>(p.getString("json"));
  }
  FILE* csv = nullptr;
  if (!p.getString("csv").empty()) {
    csv_file = std::make_unique<ptz::tools::OutputFile>(p.getString("csv"));
    csv = std::fopen(csv_file->tempPath().c_str(), "w");
    if (!csv) throw LogError(lx::kOutput, "cannot write '" + p.getString("csv") + "'");
  }
  // Closed on every way out (the temporary file itself is removed by csv_file).
  const std::unique_ptr<FILE, int (*)(FILE*)> csv_closer(
      csv, [](FILE* f) { return f ? std::fclose(f) : 0; });
  ptz::tools::SummaryOptions options;
  options.channel_prefix = prefix;
  options.target_class = p.getString("target_class");
  options.settle_s = p.getDouble("settle_s");
  options.gaps_over_s = p.getDouble("gaps_over_s");
  options.keep_heads = csv != nullptr;
  ptz::tools::LogSummary summary(options);
  while (const lcm::LogEvent* ev = log.next()) summary.add(*ev);
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
  summary.print(stdout, path, log.breaks().size(), log.truncated());
  if (json_file) {
    FILE* f = std::fopen(json_file->tempPath().c_str(), "w");
    const bool written = f && std::fputs(summary.runSummary().toJson().c_str(), f) >= 0;
    if (!f || std::fclose(f) != 0 || !written) {
      throw LogError(lx::kOutput, "cannot write '" + p.getString("json") + "'");
    }
    json_file->commit();
  }
  if (csv_file) {
    summary.writeCsv(csv);
    if (std::fflush(csv) != 0) {
      throw LogError(lx::kOutput, "cannot write '" + p.getString("csv") + "'");
    }
    csv_file->commit();
  }
  return lx::kOk;
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
  p.add("settle_s", 2.0, "s",
        "centring is measured after this much time from the first lock (the first pose with "
        "a target)",
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
