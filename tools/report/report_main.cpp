// ptz-report LOG: a folder of plots (gnuplot), the CSV behind each, summary.json (the demo's
// keys) and report.md that shows them, from a recorded LCM log. A broken log is reported as far
// as it could be read, with where it broke (on stderr and in report.md); a missing, empty or
// foreign log or one without the needed channels exits with its own code (log_exit) and leaves
// no folder: the report is made in a temporary folder and moved into place at the end.
#include <cstdio>
#include <stdexcept>
#include <string>

#include "common/config.hpp"
#include "tools/report/report.hpp"

int main(int argc, char** argv) {
  ptz::Params p("ptz-report",
                "Makes a report of a recorded run (LCM log): plots of pan/tilt/zoom setpoints and "
                "states, centring error, 3D position against ground truth, loop delay against "
                "tau_max, message rates and drops, the target track and controller state over "
                "time; their CSVs; summary.json; report.md.\n" +
                    ptz::tools::logExitCodesHelp(""));
  p.add("log", "", "the LCM log (also accepted as the only positional argument)");
  p.add("out", "", "report folder; empty: LOG's name with .report");
  p.add("channel_prefix", "", "prefix of the project's channel names in the log");
  const ptz::tools::ReportOptions d;
  p.add("target_class", d.target_class.c_str(), "class of the tracked object");
  p.add("settle_s", d.settle_s, "s",
        "summary.json's centring starts this long after the first lock (the first pose with a "
        "target)",
        ptz::Range::atLeast(0));
  p.add("dead_time_s", d.dead_time_s, "s", "the plant's dead time, added to the measured delay",
        ptz::Range::between(0, 60));
  p.add("loop_gain", d.loop_gain, "", "K of the loop whose tau_max the delay plot marks",
        ptz::Range::above(0));
  p.add("time_constant_s", d.time_constant_s, "s", "T of that loop", ptz::Range::above(0));
  std::string log_path;
  try {
    // `ptz-report LOG` as well as `ptz-report --log LOG`.
    // Every flag takes a value except --help and --help-markdown.
    std::vector<char*> args = {argv[0]};
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a.rfind("--", 0) != 0 && log_path.empty()) {
        log_path = a;
        continue;
      }
      args.push_back(argv[i]);
      if (a != "--help" && a != "--help-markdown" && i + 1 < argc) args.push_back(argv[++i]);
    }
    if (!p.parse(static_cast<int>(args.size()), args.data())) return 0;
    if (log_path.empty()) log_path = p.getString("log");
    if (log_path.empty()) throw ptz::ConfigError("a log file is required: ptz-report LOG");
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-report: %s\n", e.what());
    return ptz::tools::log_exit::kUsage;
  }
  ptz::tools::ReportOptions o;
  o.channel_prefix = p.getString("channel_prefix");
  o.target_class = p.getString("target_class");
  o.settle_s = p.getDouble("settle_s");
  o.dead_time_s = p.getDouble("dead_time_s");
  o.loop_gain = p.getDouble("loop_gain");
  o.time_constant_s = p.getDouble("time_constant_s");
  std::string dir = p.getString("out");
  if (dir.empty()) dir = log_path + ".report";
  try {
    ptz::tools::LogReader reader(log_path);
    const ptz::tools::ReportData data = ptz::tools::collectReport(reader, o);
    if (!data.breaks.empty()) {
      std::fprintf(stderr,
                   "ptz-report: warning: the log is damaged; reporting what could be read:\n%s",
                   data.breaks.c_str());
    }
    ptz::tools::OutputDir out(dir);
    std::vector<std::string> files;
    try {
      files = ptz::tools::writeReport(data, log_path, out.tempPath());
    } catch (const std::runtime_error& e) {
      throw ptz::tools::LogError(ptz::tools::log_exit::kOutput, e.what());
    }
    out.commit();
    std::printf("report: %s/report.md (%zu files)\n", dir.c_str(), files.size());
    return ptz::tools::log_exit::kOk;
  } catch (const ptz::tools::LogError& e) {
    std::fprintf(stderr, "ptz-report: %s\n", e.what());
    return e.exitCode();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptz-report: stopped: %s\n", e.what());
    return ptz::tools::log_exit::kFailed;
  }
}
