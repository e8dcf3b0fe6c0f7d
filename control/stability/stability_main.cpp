// ptz-stability: margins and the largest stable delay of the PT1 + dead-time loop (paper,
// section 4), continuous and sampled at the frame rate; Bode, Nyquist and step plots (gnuplot).
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "control/prediction/smith.hpp"
#include "control/stability/stability.hpp"
#include "control/stability/track_analysis.hpp"

namespace {

std::string num(double v) {
  if (std::isinf(v)) return "null";
  std::ostringstream s;
  s.precision(8);
  s << v;
  return s.str();
}

// Writes the data files and a gnuplot script into dir, runs gnuplot; false if it failed.
bool plot(const std::string& dir, const ptz::control::LoopParams& loop,
          const ptz::control::ContinuousMargins& m, double tau_max_sampled) {
  using namespace ptz::control;
  {
    std::ofstream f(dir + "/open_loop.dat");
    f << "# omega_rad_s magnitude_db phase_deg re im\n";
    for (const auto& p : openLoopResponse(loop, 0.1, 100, 400)) {
      f << p.omega_rad_s << " " << p.magnitude_db << " " << p.phase_deg << " " << p.re << " "
        << p.im << "\n";
    }
  }
  {
    std::ofstream f(dir + "/step.dat");
    f << "# t_s";
    const double taus[] = {0.0, 0.5 * m.tau_max_s, 0.9 * m.tau_max_s, 1.1 * m.tau_max_s};
    std::vector<std::vector<double>> ys;
    for (double tau : taus) {
      f << " tau_" << tau;
      LoopParams l = loop;
      l.delay_s = std::isfinite(tau) ? tau : 0.0;
      ys.push_back(continuousStepResponse(l, 6.0, 0.001));
    }
    f << "\n";
    for (size_t k = 0; k <= 6000; k += 5) {
      f << k * 0.001;
      for (const auto& y : ys) f << " " << (k < y.size() ? y[k] : NAN);
      f << "\n";
    }
  }
  std::ofstream g(dir + "/plots.gp");
  char tau_titles[4][64];
  const double fractions[4] = {0.0, 0.5, 0.9, 1.1};
  for (int i = 0; i < 4; ++i) {
    std::snprintf(tau_titles[i], sizeof(tau_titles[i]), "tau = %.3f s (%.0f %% of tau_max)",
                  fractions[i] * m.tau_max_s, fractions[i] * 100);
  }
  g << "set terminal pngcairo size 900,700 font 'DejaVu Sans,11' noenhanced\n"
    << "set grid\n"
    << "set output '" << dir << "/bode.png'\n"
    << "set multiplot layout 2,1 title 'Open loop G(s) = " << loop.gain << " / (1 + "
    << loop.time_constant_s << " s) e^{-s " << loop.delay_s << "}'\n"
    << "set logscale x\nset xlabel 'angular frequency (rad/s)'\nset ylabel 'magnitude (dB)'\n";
  if (m.has_crossover) {
    g << "set arrow from " << m.crossover_rad_s << ", graph 0 to " << m.crossover_rad_s
      << ", graph 1 nohead dt 2 lc rgb 'red'\n"
      << "set label sprintf('omega_g = %.3f rad/s', " << m.crossover_rad_s << ") at "
      << m.crossover_rad_s << ", graph 0.9 offset 1,0 tc rgb 'red'\n";
  }
  g << "plot '" << dir << "/open_loop.dat' using 1:2 with lines lw 2 title '|G(j omega)|', 0 "
    << "title '0 dB' dt 3 lc rgb 'gray'\n"
    << "set ylabel 'phase (deg)'\n"
    << "set label sprintf('phase margin %.1f deg', " << m.phase_margin_at_delay_deg
    << ") at graph 0.05, graph 0.15\n"
    << "plot '" << dir << "/open_loop.dat' using 1:3 with lines lw 2 title 'arg G(j omega)', -180 "
    << "title '-180 deg' dt 3 lc rgb 'gray'\n"
    << "unset multiplot\nunset arrow\nunset label\nunset logscale x\n"
    << "set output '" << dir << "/nyquist.png'\n"
    << "set title sprintf('Nyquist plot, tau = %.3f s (tau_max %.3f s continuous, %.3f s "
    << "sampled)', " << loop.delay_s << ", " << m.tau_max_s << ", " << tau_max_sampled << ")\n"
    << "set xlabel 'Re G(j omega)'\nset ylabel 'Im G(j omega)'\nset size ratio -1\n"
    << "set xrange [-2:2]\nset yrange [-2:2]\nset parametric\nset trange [0:2*pi]\n"
    << "set label 'critical point -1' at -1,0 point pt 7 lc rgb 'red' offset 1,1\n"
    << "plot '" << dir
    << "/open_loop.dat' using 4:5 with lines lw 2 title 'G(j omega), omega > 0', "
    << "cos(t), sin(t) dt 3 lc rgb 'gray' title 'unit circle'\n"
    << "unset parametric\nunset label\nset size noratio\nset autoscale\n"
    << "set output '" << dir << "/step.png'\n"
    << "set title 'Closed-loop step response (unity feedback), continuous'\n"
    << "set xlabel 'time (s)'\nset ylabel 'output / reference step'\nset yrange [-0.5:2.5]\n"
    << "plot '" << dir << "/step.dat' using 1:2 with lines lw 2 title '" << tau_titles[0] << "', "
    << "'' using 1:3 with lines lw 2 title '" << tau_titles[1] << "', "
    << "'' using 1:4 with lines lw 2 title '" << tau_titles[2] << "', "
    << "'' using 1:5 with lines lw 2 title '" << tau_titles[3] << "'\n";
  g.close();
  return std::system(("gnuplot '" + dir + "/plots.gp'").c_str()) == 0;
}

// The Smith loop's step response for a plant off from its model, at this frame rate.
struct SmithCase {
  double k_scale, t_scale, tau_scale;
  std::vector<double> y;
  ptz::control::StepFigures f;
};

std::vector<SmithCase> smithSensitivity(double motor_gain, double time_constant_s, double delay_s,
                                        double fps) {
  std::vector<SmithCase> cases;
  auto add = [&](double k, double t, double tau) {
    ptz::AxisParams plant;
    plant.gain = motor_gain * k;
    plant.time_constant_s = time_constant_s * t;
    plant.dead_time_s = delay_s * tau;
    ptz::control::SmithParams smith;
    smith.model.gain = motor_gain;
    smith.model.time_constant_s = time_constant_s;
    smith.model.dead_time_s = delay_s;
    SmithCase c{
        k, t, tau, ptz::control::smithStepResponse(plant, smith, fps, 6.0 + 6 * delay_s), {}};
    c.f = ptz::control::stepFigures(c.y, fps);
    cases.push_back(std::move(c));
  };
  for (double k : {0.7, 1.0, 1.3}) {
    for (double t : {0.7, 1.0, 1.3}) add(k, t, 1.0);
  }
  for (double tau : {0.8, 0.9, 1.1, 1.2, 1.5, 2.0}) add(1.0, 1.0, tau);
  return cases;
}

void printSmith(const std::vector<SmithCase>& cases, double delay_s, double fps) {
  std::printf(
      "\nsmith mode (Smith predictor, model K, T, tau = plant's nominal), tau = %g s, %g Hz;\n"
      "step responses with the real plant off from the model:\n"
      "  plant K   plant T   plant tau   overshoot   settling (5 %%)   final error   decays\n",
      delay_s, fps);
  for (const auto& c : cases) {
    std::printf("  x%-7.2f x%-7.2f x%-9.2f %7.1f %%   %10.2f s   %11.4f   %s\n", c.k_scale,
                c.t_scale, c.tau_scale, 100 * c.f.overshoot, c.f.settling_time_s, c.f.final_error,
                c.f.decays ? "yes" : "NO");
  }
}

bool plotSmith(const std::string& dir, const std::vector<SmithCase>& cases, double delay_s,
               double fps) {
  std::ofstream f(dir + "/smith_step.dat");
  std::ofstream g(dir + "/smith.gp");
  g << "set terminal pngcairo size 1150,600 font 'DejaVu Sans,11' noenhanced\nset grid\n"
    << "set key outside right\nset yrange [0:2]\n"
    << "set output '" << dir << "/smith_step.png'\n"
    << "set title 'Smith predictor, tau = " << delay_s << " s, " << fps
    << " Hz: step responses with the plant off from the model'\n"
    << "set xlabel 'time (s)'\nset ylabel 'output / reference step'\nplot ";
  size_t n = 0;
  for (const auto& c : cases) n = std::max(n, c.y.size());
  for (size_t k = 0; k < n; ++k) {
    f << k / fps;
    for (const auto& c : cases) f << " " << (k < c.y.size() ? c.y[k] : NAN);
    f << "\n";
  }
  bool first = true;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto& c = cases[i];
    // The corners of the +-30 % box and the delay errors; the rest only crowd the plot.
    if (c.k_scale != 1.0 && c.t_scale == 1.0) continue;
    if (c.k_scale == 1.0 && c.t_scale != 1.0) continue;
    char title[96];
    std::snprintf(title, sizeof(title), "plant K x%.1f, T x%.1f, tau x%.1f", c.k_scale, c.t_scale,
                  c.tau_scale);
    g << (first ? "" : ", ") << "'" << dir << "/smith_step.dat' using 1:" << i + 2
      << " with lines lw 2 dt " << (c.tau_scale != 1.0 ? 2 : 1) << " title '" << title << "'";
    first = false;
  }
  g << "\n";
  g.close();
  return std::system(("gnuplot '" + dir + "/smith.gp'").c_str()) == 0;
}

}  // namespace

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
    control::LoopParams loop{p.getDouble("gain"), p.getDouble("time_constant_s"),
                             p.getDouble("delay_s")};
    // The sampled loop has a state per frame of delay (an eigenvalue problem of that size).
    if (loop.delay_s * p.getDouble("frame_rate_hz") > 1000) {
      throw p.invalid("delay_s", "must span at most 1000 frames at frame_rate_hz " +
                                     p.getString("frame_rate_hz"));
    }
    const auto m = control::continuousMargins(loop);
    const double fps = p.getDouble("frame_rate_hz");
    const double tau_sampled = fps > 0 ? control::sampledTauMax(loop, fps) : NAN;
    const auto sampled = fps > 0 ? control::sampledStability(loop, fps) : control::SampledResult{};
    std::printf("open loop G(s) = %g / (1 + %g s) * exp(-s * %g)\n", loop.gain,
                loop.time_constant_s, loop.delay_s);
    if (!m.has_crossover) {
      std::printf(
          "|K| <= 1: |G(j w)| < 1 at every frequency, no gain crossover: the continuous "
          "loop is stable for every delay\n");
    } else {
      std::printf("gain crossover      omega_g = %.3f rad/s\n", m.crossover_rad_s);
      std::printf("phase margin        %.1f deg without delay, %.1f deg at tau = %g s\n",
                  m.phase_margin_deg, m.phase_margin_at_delay_deg, loop.delay_s);
      std::printf("largest delay       tau_max = %.3f s (continuous)\n", m.tau_max_s);
    }
    if (loop.delay_s > 0) {
      std::printf("gain margin         %.2f dB at %.3f rad/s\n", m.gain_margin_db,
                  m.phase_crossover_rad_s);
    }
    if (fps > 0) {
      std::printf(
          "sampled at %g Hz    tau_max = %.3f s; at tau = %g s the largest pole is %.4f "
          "(%s)\n",
          fps, tau_sampled, loop.delay_s, sampled.spectral_radius,
          sampled.stable ? "stable" : "unstable");
    }
    std::printf("at tau = %g s the continuous loop is %s\n", loop.delay_s,
                m.stable ? "stable" : "unstable");
    const control::TrackLoopParams track{loop.time_constant_s, p.getDouble("lead_s"),
                                         p.getDouble("rate_filter_s"), loop.delay_s};
    const control::TrackMargins tm = control::trackLoopMargins(track);
    std::printf(
        "\ntrack mode (the default; lead %g s, Tv %g s): the image feeds back only through rig "
        "model error, g rad of measured target angle per rad of camera angle;\n"
        "  stable for every delay while |g| < %.3f (peak |P F| = %.3f); at tau = %g s: "
        "-%.3f < g < %.3f\n",
        track.lead_s, track.rate_filter_s, tm.g_max_any_delay, tm.peak_gain, loop.delay_s,
        tm.g_max_negative, tm.g_max_positive);
    const bool smith = p.getBool("smith");
    std::vector<SmithCase> smith_cases;
    if (smith) {
      if (!(fps > 0)) throw ConfigError("--smith needs frame_rate_hz > 0 (the loop is sampled)");
      smith_cases =
          smithSensitivity(p.getDouble("motor_gain"), loop.time_constant_s, loop.delay_s, fps);
      printSmith(smith_cases, loop.delay_s, fps);
    }
    const std::string json = p.getString("json");
    if (!json.empty()) {
      std::ofstream f(json);
      f << "{\n  \"gain\": " << num(loop.gain)
        << ",\n  \"time_constant_s\": " << num(loop.time_constant_s)
        << ",\n  \"delay_s\": " << num(loop.delay_s)
        << ",\n  \"has_crossover\": " << (m.has_crossover ? "true" : "false")
        << ",\n  \"crossover_rad_s\": " << num(m.crossover_rad_s)
        << ",\n  \"phase_margin_deg\": " << num(m.phase_margin_deg)
        << ",\n  \"phase_margin_at_delay_deg\": " << num(m.phase_margin_at_delay_deg)
        << ",\n  \"gain_margin_db\": " << num(m.gain_margin_db)
        << ",\n  \"tau_max_s\": " << num(m.tau_max_s)
        << ",\n  \"stable\": " << (m.stable ? "true" : "false")
        << ",\n  \"frame_rate_hz\": " << num(fps)
        << ",\n  \"sampled_tau_max_s\": " << (fps > 0 ? num(tau_sampled) : "null")
        << ",\n  \"sampled_spectral_radius\": " << (fps > 0 ? num(sampled.spectral_radius) : "null")
        << ",\n  \"sampled_stable\": " << (fps > 0 ? (sampled.stable ? "true" : "false") : "null")
        << ",\n  \"track_g_max_any_delay\": " << num(tm.g_max_any_delay)
        << ",\n  \"track_g_max_positive\": " << num(tm.g_max_positive)
        << ",\n  \"track_g_max_negative\": " << num(tm.g_max_negative);
      if (smith) {
        f << ",\n  \"smith\": [";
        for (size_t i = 0; i < smith_cases.size(); ++i) {
          const auto& c = smith_cases[i];
          f << (i ? ",\n    " : "\n    ") << "{\"plant_gain_scale\": " << num(c.k_scale)
            << ", \"plant_time_constant_scale\": " << num(c.t_scale)
            << ", \"plant_delay_scale\": " << num(c.tau_scale)
            << ", \"overshoot\": " << num(c.f.overshoot)
            << ", \"settling_time_s\": " << num(c.f.settling_time_s)
            << ", \"final_error\": " << num(c.f.final_error)
            << ", \"decays\": " << (c.f.decays ? "true" : "false") << "}";
        }
        f << "\n  ]";
      }
      f << "\n}\n";
      if (!f) throw ConfigError("cannot write '" + json + "'");
    }
    const std::string dir = p.getString("plots");
    if (!dir.empty()) {
      ::mkdir(dir.c_str(), 0755);
      if (!plot(dir, loop, m, tau_sampled)) {
        std::fprintf(stderr, "ptz-stability: gnuplot failed (is gnuplot installed?)\n");
        return 1;
      }
      std::printf("plots: %s/bode.png %s/nyquist.png %s/step.png\n", dir.c_str(), dir.c_str(),
                  dir.c_str());
      if (smith && !plotSmith(dir, smith_cases, loop.delay_s, fps)) {
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
