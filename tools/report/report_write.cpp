#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "common/transport/transport.hpp"
#include "tools/report/report.hpp"

namespace ptz::tools {
namespace {

std::ofstream open(const std::string& path) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write '" + path + "'");
  f.precision(9);
  return f;
}

void writePtz(const std::string& path, const std::vector<ReportData::Ptz>& rows) {
  auto f = open(path);
  f << "t_s,left_pan_rad,left_tilt_rad,left_zoom,right_pan_rad,right_tilt_rad,right_zoom\n";
  for (const auto& r : rows) {
    f << r.t_s;
    for (double v : r.v) f << "," << v;
    f << "\n";
  }
}

// A name from the log (channel, process, counter) as one CSV field or Markdown table cell:
// control characters, separators and pipes replaced so it cannot add a row or a column.
std::string fieldText(const std::string& s) {
  std::string out;
  for (const char c : s) {
    const bool control = static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
    out += control || c == ',' || c == '|' ? '?' : c;
  }
  return out;
}

// Text from the log (channel, process and counter names) as the inside of a single-quoted
// gnuplot string: a quote doubled, control characters replaced, so a name cannot end the
// string or the line and run commands of its own.
std::string gnuplotText(const std::string& s) {
  std::string out;
  for (const char c : s) {
    if (c == '\'') {
      out += "''";
    } else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      out += '?';
    } else {
      out += c;
    }
  }
  return out;
}

// A distinct colour for series k of n: 20 hand-picked, well separated colours (tab20 reordered:
// the saturated ten first), then hues around the circle (golden angle) for more.
std::string seriesColour(size_t k) {
  static const char* const kPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                         "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
                                         "#000080", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5",
                                         "#c49c94", "#f7b6d2", "#404040", "#dbdb8d", "#9edae5"};
  constexpr size_t kNamed = sizeof(kPalette) / sizeof(kPalette[0]);
  if (k < kNamed) return kPalette[k];
  const double hue = std::fmod((k - kNamed) * 137.507764 + 15.0, 360.0) / 60.0;
  const double level = 0.35 + 0.1 * static_cast<double>((k - kNamed) % 3);  // value steps
  const double x = 1 - std::fabs(std::fmod(hue, 2.0) - 1);
  double rgb[3] = {0, 0, 0};
  const int sector = static_cast<int>(hue);
  const int hi[6] = {0, 1, 1, 2, 2, 0}, mid[6] = {1, 0, 2, 1, 0, 2};
  rgb[hi[sector]] = 1;
  rgb[mid[sector]] = x;
  char text[8];
  std::snprintf(text, sizeof(text), "#%02x%02x%02x", static_cast<int>(255 * (1 - level) * rgb[0]),
                static_cast<int>(255 * (1 - level) * rgb[1]),
                static_cast<int>(255 * (1 - level) * rgb[2]));
  return text;
}

// One gnuplot script for every figure: labelled axes with units, legends, a title each. Paths
// are relative: the script runs inside the report folder (wherever it is moved to).
std::string gnuplotScript(const ReportData& d) {
  std::ostringstream g;
  const std::string q = "'";
  // Fixed margins: the panels of a figure line up whatever their legends.
  g << "set terminal pngcairo size 1000,750 font 'DejaVu Sans,11' noenhanced\n"
    << "set datafile separator ','\nset grid\nset key outside right\n"
    << "set lmargin at screen 0.08\nset rmargin at screen 0.70\n";
  if (!d.states.empty() || !d.setpoints.empty()) {
    g << "set output " << q << "ptz.png'\n"
      << "set multiplot layout 3,1 title 'Pan, tilt and zoom: state (solid) and setpoint "
         "(dashed, at the capture time of the frame it answers)'\n"
      << "set xlabel 'time (s)'\n";
    const char* names[3] = {"pan (deg)", "tilt (deg)", "zoom (ratio)"};
    for (int a = 0; a < 3; ++a) {
      const std::string scale = a < 2 ? "*180/pi" : "";
      g << "set ylabel '" << names[a] << "'\nplot " << q << "states.csv' using 1:($" << a + 2
        << scale << ") skip 1 with lines lw 2 lc rgb '#1f77b4' title 'left state', " << q
        << "states.csv' using 1:($" << a + 5 << scale
        << ") skip 1 with lines lw 2 lc rgb '#d62728' title 'right state', " << q
        << "setpoints.csv' using 1:($" << a + 2 << scale
        << ") skip 1 with lines dt 2 lc rgb '#1f77b4' title 'left setpoint', " << q
        << "setpoints.csv' using 1:($" << a + 5 << scale
        << ") skip 1 with lines dt 2 lc rgb '#d62728' title 'right setpoint'\n";
    }
    g << "unset multiplot\n";
  }
  if (!d.centring.empty()) {
    g << "set output " << q << "centring.png'\nset title 'Centring error: "
      << (d.centring_source == "SIM_TRUTH" ? "the true target" : "the detected target")
      << " to the image centre (" << d.centring_source << ")'\n"
      << "set xlabel 'time (s)'\nset ylabel 'distance from the image centre (VGA-equivalent px)'\n"
      << "plot " << q << "centring.csv' using 1:6 skip 1 with lines lw 2 title 'left camera', " << q
      << "centring.csv' using 1:7 skip 1 with lines lw 2 title 'right camera'\nunset title\n";
  }
  if (!d.positions.empty()) {
    const bool truth = std::any_of(d.positions.begin(), d.positions.end(),
                                   [](const auto& p) { return p.has_truth; });
    g << "set output " << q << "position.png'\n"
      << "set multiplot layout " << (truth ? 2 : 1) << ",1 title 'Target position in the "
      << "head frame: estimate (solid)" << (truth ? " and ground truth (dashed)" : "") << "'\n"
      << "set xlabel 'time (s)'\nset ylabel 'position (m)'\nplot ";
    const char* axes[3] = {"x", "y", "z"};
    const char* colours[3] = {"#1f77b4", "#2ca02c", "#d62728"};
    for (int k = 0; k < 3; ++k) {
      g << (k ? ", " : "") << q << "position.csv' using 1:" << k + 2
        << " skip 1 with lines lw 2 lc rgb '" << colours[k] << "' title '" << axes[k]
        << " estimate'";
      if (truth) {
        g << ", " << q << "position.csv' using 1:" << k + 5 << " skip 1 with lines dt 2 lc rgb '"
          << colours[k] << "' title '" << axes[k] << " truth'";
      }
    }
    g << "\n";
    if (truth) {
      g << "set ylabel '3D error (mm)'\nplot " << q
        << "position.csv' using 1:($8*1000) skip 1 with lines lw 2 title '|estimate - truth|'\n";
    }
    g << "unset multiplot\n";
  }
  if (!d.target_tracks.empty() || !d.control.empty()) {
    const int panels = (d.target_tracks.empty() ? 0 : 1) + (d.control.empty() ? 0 : 1);
    g << "set output " << q << "tracks.png'\n"
      << "set multiplot layout " << panels << ",1 title 'The target track and the controller "
      << "state'\nset xlabel 'time (s)'\nset lmargin at screen 0.11\n";
    if (!d.target_tracks.empty()) {
      // The target a wide line; each live track a dot on it at its id, coloured by its state.
      g << "set ylabel 'track id (-1: none)'\nplot " << q
        << "target.csv' using 1:2 skip 1 with steps lw 6 lc rgb '#f4a6a6' title 'target "
        << "(OBJECT_TRACKS)', " << q
        << "target.csv' using 1:3 skip 1 with steps dt 2 lc rgb '#7f7f7f' title 'live tracks', "
        << q << "tracks.csv' using 1:2:($3 == 0 ? 0xaaaaaa : $3 == 1 ? 0x2ca02c : 0xff7f0e) "
        << "skip 1 with points pt 7 ps 0.4 lc rgb variable notitle, "
        << "NaN with points pt 7 lc rgb '#aaaaaa' title 'tentative', "
        << "NaN with points pt 7 lc rgb '#2ca02c' title 'confirmed', "
        << "NaN with points pt 7 lc rgb '#ff7f0e' title 'coasting'\n";
    }
    if (!d.control.empty()) {
      g << "set ylabel 'ptz-control state'\nset yrange [-0.5:4.5]\n"
        << "set ytics ('tracking' 0, 'coasting' 1, 'searching' 2, 'holding' 3, 'homing' 4)\n"
        << "plot " << q
        << "control_state.csv' using 1:2 skip 1 with steps lw 2 lc rgb '#1f77b4' title "
        << "'CONTROL_STATE'\n"
        << "set ytics autofreq\nset autoscale y\n";
    }
    g << "unset multiplot\nset lmargin at screen 0.08\n";
  }
  if (!d.delay_ms.empty()) {
    g << "set output " << q << "delay.png'\nset style fill solid 0.5\n"
      << "set multiplot layout 2,1 title 'Loop delay: " << d.delay_what << "'\n"
      << "set xlabel 'delay (ms)'\nset ylabel 'setpoints'\nset xrange [0:*]\n"
      << "plot " << q << "delay.csv' using 1 skip 1 bins=40 with boxes title 'delay'\n";
    if (d.tau_max_ms > 0) {
      g << "set xrange [0:" << 1.2 * d.tau_max_ms << "]\n"
        << "set arrow from " << d.tau_max_ms << ", graph 0 to " << d.tau_max_ms
        << ", graph 1 nohead lw 2 lc rgb 'red'\n"
        << "set label sprintf('tau_max %.0f ms (paper loop, sampled at %.0f Hz)', " << d.tau_max_ms
        << ", " << d.frame_rate_hz << ") at " << d.tau_max_ms
        << ", graph 0.9 right offset -1,0 tc rgb 'red'\n"
        << "plot " << q
        << "delay.csv' using 1 skip 1 bins=40 with boxes title 'delay, against the limit'\n"
        << "unset arrow\nunset label\n";
    }
    g << "unset multiplot\nset autoscale x\nset style fill empty\n";
  }
  if (!d.messages_per_bin.empty()) {
    g << "set output " << q << "rates.png'\nset multiplot layout 2,1 title 'Message rates by "
      << "channel (log time, " << d.bin_s << " s bins) and drops'\n"
      << "set xlabel 'log time (s)'\nset ylabel 'messages/s'\nplot ";
    int col = 2;
    for (const auto& [name, v] : d.messages_per_bin) {
      g << (col > 2 ? ", " : "") << q << "rates.csv' using 1:($" << col << "/" << d.bin_s << ")";
      g << " skip 1 with steps lw 2 lc rgb '" << seriesColour(col - 2) << "' title '"
        << gnuplotText(name) << "'";
      ++col;
    }
    int64_t most = d.frames_missing_cumulative.empty() ? 0 : d.frames_missing_cumulative.back();
    for (const auto& [name, v] : d.dropped_cumulative) most = std::max(most, v.back());
    g << "\nset ylabel 'dropped (cumulative)'\nset yrange [0:"
      << std::max<int64_t>(1, most * 11 / 10 + 1) << "]\nplot " << q
      << "drops.csv' using 1:2 skip 1 with steps lw 2 lc rgb '" << seriesColour(0)
      << "' title 'stereo frames missing (seq gaps)'";
    col = 3;
    for (const auto& [name, v] : d.dropped_cumulative) {
      g << ", " << q << "drops.csv' using 1:" << col << " skip 1 with steps lw 2 lc rgb '"
        << seriesColour(col - 2) << "' title '" << gnuplotText(name) << "'";
      ++col;
    }
    g << "\nunset multiplot\nset autoscale y\n";
  }
  return g.str();
}

std::string reportMarkdown(const ReportData& d, const std::string& log_path,
                           const std::vector<std::string>& pngs) {
  std::ostringstream m;
  m << "# Run report\n\nLog: `" << log_path << "`, " << d.duration_s << " s, frames at "
    << d.frame_rate_hz << " Hz.\n\n";
  if (!d.breaks.empty())
    m << "**The log is broken; this report covers what could be read:**\n\n```\n"
      << d.breaks << "```\n\n";
  if (d.undecodable > 0) m << "Undecodable messages: " << d.undecodable << ".\n\n";
  m << "## Summary (`summary.json`)\n\n```json\n" << d.summary.toJson() << "```\n\n";
  const std::map<std::string, std::string> captions = {
      {"ptz.png", "Pan, tilt and zoom of both cameras: state and setpoint"},
      {"centring.png", "Centring error (" + d.centring_source + ")"},
      {"position.png", "3D position of the target"},
      {"tracks.png", "Target track and controller state over time"},
      {"delay.png", "Loop delay (" + d.delay_what + ")"},
      {"rates.png", "Message rates and drops per channel"}};
  for (const auto& png : pngs) {
    m << "## " << captions.at(png) << "\n\n![" << captions.at(png) << "](" << png << ")\n\n";
  }
  m << "## Messages\n\n| channel | messages |\n|---|---|\n";
  for (const auto& [name, n] : d.channel_messages)
    m << "| " << fieldText(name) << " | " << n << " |\n";
  return m.str();
}

// gnuplot on the script, in the folder, without a shell: nothing in the folder's name is
// interpreted. Its output is kept for the error message.
void runGnuplot(const std::string& dir, const std::string& script) {
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0)
    throw std::runtime_error("pipe: " + std::string(std::strerror(errno)));
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, dir.c_str());
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDERR_FILENO);
  std::string program = "gnuplot", arg = script;
  char* argv[] = {program.data(), arg.data(), nullptr};
  pid_t pid = 0;
  const int spawned = ::posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(pipe_fds[1]);
  if (spawned != 0) {
    ::close(pipe_fds[0]);
    if (spawned == ENOENT) {
      throw std::runtime_error(
          "gnuplot is not installed (not found on PATH); the plots' script is '" + dir + "/" +
          script + "'");
    }
    throw std::runtime_error("cannot run gnuplot in '" + dir + "': " + std::strerror(spawned));
  }
  std::string output;
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(pipe_fds[0], buf, sizeof(buf));
    if (n > 0) {
      if (output.size() < 64 * 1024) output.append(buf, static_cast<size_t>(n));
    } else if (n == 0 || errno != EINTR) {
      break;
    }
  }
  ::close(pipe_fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    const std::string how = WIFEXITED(status) ? "exit code " + std::to_string(WEXITSTATUS(status))
                                              : "signal " + std::to_string(WTERMSIG(status));
    throw std::runtime_error("gnuplot failed (" + how + ") on '" + dir + "/" + script + "'" +
                             (output.empty() ? "" : ":\n" + output));
  }
}

}  // namespace

std::vector<std::string> writeReport(const ReportData& d, const std::string& log_path,
                                     const std::string& dir) {
  ::mkdir(dir.c_str(), 0755);
  std::vector<std::string> files, pngs;
  writePtz(dir + "/setpoints.csv", d.setpoints);
  writePtz(dir + "/states.csv", d.states);
  files.insert(files.end(), {"setpoints.csv", "states.csv"});
  if (!d.states.empty() || !d.setpoints.empty()) pngs.push_back("ptz.png");
  if (!d.centring.empty()) {
    auto f = open(dir + "/centring.csv");
    f << "t_s,left_dx_px,left_dy_px,right_dx_px,right_dy_px,left_px,right_px\n";
    for (const auto& c : d.centring) {
      f << c.t_s << "," << c.px[0] << "," << c.px[1] << "," << c.px[2] << "," << c.px[3] << ","
        << std::hypot(c.px[0], c.px[1]) << "," << std::hypot(c.px[2], c.px[3]) << "\n";
    }
    files.push_back("centring.csv");
    pngs.push_back("centring.png");
  }
  if (!d.positions.empty()) {
    auto f = open(dir + "/position.csv");
    f << "t_s,x_m,y_m,z_m,true_x_m,true_y_m,true_z_m,error_m\n";
    for (const auto& p : d.positions) {
      f << p.t_s << "," << p.estimate_m[0] << "," << p.estimate_m[1] << "," << p.estimate_m[2];
      if (p.has_truth) {
        const double e = std::hypot(p.estimate_m[0] - p.truth_m[0], p.estimate_m[1] - p.truth_m[1],
                                    p.estimate_m[2] - p.truth_m[2]);
        f << "," << p.truth_m[0] << "," << p.truth_m[1] << "," << p.truth_m[2] << "," << e << "\n";
      } else {
        f << ",,,,\n";
      }
    }
    files.push_back("position.csv");
    pngs.push_back("position.png");
  }
  if (!d.target_tracks.empty()) {
    auto f = open(dir + "/target.csv");
    f << "t_s,target_id,tracks\n";
    for (const auto& t : d.target_tracks)
      f << t.t_s << "," << t.target_id << "," << t.tracks << "\n";
    files.push_back("target.csv");
    auto points = open(dir + "/tracks.csv");
    points << "t_s,track_id,state\n";
    for (const auto& p : d.track_points) points << p.t_s << "," << p.id << "," << p.state << "\n";
    files.push_back("tracks.csv");
  }
  if (!d.control.empty()) {
    auto f = open(dir + "/control_state.csv");
    f << "t_s,state,target_id\n";
    for (const auto& c : d.control) f << c.t_s << "," << c.state << "," << c.target_id << "\n";
    files.push_back("control_state.csv");
  }
  if (!d.target_tracks.empty() || !d.control.empty()) pngs.push_back("tracks.png");
  if (!d.delay_ms.empty()) {
    auto f = open(dir + "/delay.csv");
    f << "delay_ms\n";
    for (double v : d.delay_ms) f << v << "\n";
    files.push_back("delay.csv");
    pngs.push_back("delay.png");
  }
  {
    auto f = open(dir + "/rates.csv");
    f << "t_s";
    for (const auto& [name, v] : d.messages_per_bin) f << "," << fieldText(name);
    f << "\n";
    auto g = open(dir + "/drops.csv");
    g << "t_s,STEREO_FRAME_missing";
    for (const auto& [name, v] : d.dropped_cumulative) g << "," << fieldText(name);
    g << "\n";
    for (size_t s = 0;
         s < d.frames_missing_cumulative.size() ||
         (!d.messages_per_bin.empty() && s < d.messages_per_bin.begin()->second.size());
         ++s) {
      f << s * d.bin_s;
      for (const auto& [name, v] : d.messages_per_bin) f << "," << (s < v.size() ? v[s] : 0);
      f << "\n";
      g << s * d.bin_s << ","
        << (s < d.frames_missing_cumulative.size() ? d.frames_missing_cumulative[s] : 0);
      for (const auto& [name, v] : d.dropped_cumulative) g << "," << (s < v.size() ? v[s] : 0);
      g << "\n";
    }
    files.insert(files.end(), {"rates.csv", "drops.csv"});
    pngs.push_back("rates.png");
  }
  open(dir + "/plots.gp") << gnuplotScript(d);
  runGnuplot(dir, "plots.gp");
  open(dir + "/summary.json") << d.summary.toJson();
  open(dir + "/report.md") << reportMarkdown(d, log_path, pngs);
  files.insert(files.end(), {"plots.gp", "summary.json", "report.md"});
  files.insert(files.end(), pngs.begin(), pngs.end());
  return files;
}

}  // namespace ptz::tools
