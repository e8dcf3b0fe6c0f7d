// ptz-stability: margins and the largest stable delay of the PT1 + dead-time loop (paper,
// section 4), continuous and sampled at the frame rate; Bode, Nyquist and step plots (gnuplot).
// The figures, their text and JSON are stability_report.hpp's, the plots stability_plots.hpp's.
#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "common/config.hpp"
#include "control/stability/stability_plots.hpp"
#include "control/stability/stability_report.hpp"

int main(int argc, char** argv) {
  using namespace ptz;
  Params p("ptz-stability",
           "Stability of one axis of the active vision loop: the open loop K / (1 + T s) "
           "e^(-s tau) with unity feedback (paper, eq. 9-14): gain crossover, phase and gain "
           "margins, the largest stable delay tau_max, continuous and sampled at the frame rate.");
  p.add("gain", 1.7, "", "open-loop gain K (controller P times motor gain)", ptz::Range::above(0));
  p.add("time_constant_s", 0.24, "s", "motor time constant T", ptz::Range::above(0));
  p.add("delay_s", 0.0, "s", "delay tau (image processing, transport)", ptz::Range::between(0, 60));
  p.add("frame_rate_hz", 30.0, "Hz", "frame rate of the sampled loop (0: continuous only)",
        ptz::Range::between(0, 10000));
  p.add("json", "", "also write every figure as JSON to this file");
  p.add("plots", "", "folder for bode.png, nyquist.png, step.png (gnuplot)");
  p.add("smith", false,
        "also the smith mode's sensitivity to a wrong plant model (K, T off by 30 %, tau off); "
        "the plant is motor_gain / (1 + T s) e^(-s tau)");
  p.add("motor_gain", 1.0, "", "smith: the motor's own gain (without the paper's P element)",
        ptz::Range::above(0));
  const control::TrackLoopParams track_default;
  p.add("lead_s", track_default.lead_s, "s",
        "track: the feed-forward horizon of ptz-control's track mode", ptz::Range::atLeast(0));
  p.add("rate_filter_s", track_default.rate_filter_s, "s",
        "track: the time constant of its rate estimate", ptz::Range::above(0));
  try {
    if (!p.parse(argc, argv)) return 0;
    const control::LoopParams loop{p.getDouble("gain"), p.getDouble("time_constant_s"),
                                   p.getDouble("delay_s")};
    const double fps = p.getDouble("frame_rate_hz");
    // The sampled loop has a state per frame of delay (an eigenvalue problem of that size).
    if (loop.delay_s * fps > 1000) {
      throw p.invalid("delay_s", "must span at most 1000 frames at frame_rate_hz " +
                                     p.getString("frame_rate_hz"));
    }
    const bool smith = p.getBool("smith");
    if (smith && !(fps > 0)) {
      throw ConfigError("--smith needs frame_rate_hz > 0 (the loop is sampled)");
    }
    const control::TrackLoopParams track{loop.time_constant_s, p.getDouble("lead_s"),
                                         p.getDouble("rate_filter_s"), loop.delay_s};
    const control::StabilityFigures f =
        control::analyseStability(loop, fps, track, smith ? p.getDouble("motor_gain") : 0.0);
    std::fputs(control::stabilityText(f).c_str(), stdout);
    const std::string json = p.getString("json");
    if (!json.empty()) {
      std::ofstream out(json);
      out << control::stabilityJson(f);
      if (!out) throw ConfigError("cannot write '" + json + "'");
    }
    const std::string dir = p.getString("plots");
    if (!dir.empty()) {
      ::mkdir(dir.c_str(), 0755);
      if (!control::plotLoop(dir, loop, f.margins, f.sampled_tau_max_s)) {
        std::fprintf(stderr, "ptz-stability: gnuplot failed (is gnuplot installed?)\n");
        return 1;
      }
      std::printf("plots: %s/bode.png %s/nyquist.png %s/step.png\n", dir.c_str(), dir.c_str(),
                  dir.c_str());
      if (smith && !control::plotSmith(dir, f.smith, loop.delay_s, fps)) {
        std::fprintf(stderr, "ptz-stability: gnuplot failed on the smith plot\n");
        return 1;
      }
      if (smith) std::printf("smith plot: %s/smith_step.png\n", dir.c_str());
    }
    return 0;
  } catch (const ConfigError& e) {
    std::fprintf(stderr, "ptz-stability: %s\n", e.what());
    return 2;
  }
}
