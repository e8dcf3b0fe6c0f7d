#include "control/stability/stability_report.hpp"

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <sstream>

namespace ptz::control {
namespace {

// printf onto the end of *out.
void appendf(std::string* out, const char* format, ...) __attribute__((format(printf, 2, 3)));
void appendf(std::string* out, const char* format, ...) {
  va_list args;
  va_start(args, format);
  char buffer[512];
  std::vsnprintf(buffer, sizeof(buffer), format, args);
  va_end(args);
  *out += buffer;
}

std::string num(double v) {
  if (std::isinf(v)) return "null";
  std::ostringstream s;
  s.precision(8);
  s << v;
  return s.str();
}

const char* boolean(bool b) {
  return b ? "true" : "false";
}

}  // namespace

std::vector<SmithCase> smithSensitivity(double motor_gain, double time_constant_s, double delay_s,
                                        double frame_rate_hz) {
  std::vector<SmithCase> cases;
  auto add = [&](double k, double t, double tau) {
    AxisParams plant;
    plant.gain = motor_gain * k;
    plant.time_constant_s = time_constant_s * t;
    plant.dead_time_s = delay_s * tau;
    SmithParams smith;
    smith.model.gain = motor_gain;
    smith.model.time_constant_s = time_constant_s;
    smith.model.dead_time_s = delay_s;
    SmithCase c{k, t, tau, smithStepResponse(plant, smith, frame_rate_hz, 6.0 + 6 * delay_s), {}};
    c.f = stepFigures(c.y, frame_rate_hz);
    cases.push_back(std::move(c));
  };
  for (double k : {0.7, 1.0, 1.3}) {
    for (double t : {0.7, 1.0, 1.3}) add(k, t, 1.0);
  }
  for (double tau : {0.8, 0.9, 1.1, 1.2, 1.5, 2.0}) add(1.0, 1.0, tau);
  return cases;
}

StabilityFigures analyseStability(const LoopParams& loop, double frame_rate_hz,
                                  const TrackLoopParams& track, double smith_motor_gain) {
  StabilityFigures f;
  f.loop = loop;
  f.frame_rate_hz = frame_rate_hz;
  f.margins = continuousMargins(loop);
  f.sampled_tau_max_s = frame_rate_hz > 0 ? sampledTauMax(loop, frame_rate_hz) : NAN;
  if (frame_rate_hz > 0) f.sampled = sampledStability(loop, frame_rate_hz);
  f.track = track;
  f.track_margins = trackLoopMargins(track);
  if (smith_motor_gain > 0) {
    f.smith = smithSensitivity(smith_motor_gain, loop.time_constant_s, loop.delay_s, frame_rate_hz);
  }
  return f;
}

std::string stabilityText(const StabilityFigures& f) {
  const LoopParams& loop = f.loop;
  const ContinuousMargins& m = f.margins;
  const double fps = f.frame_rate_hz;
  std::string s;
  appendf(&s, "open loop G(s) = %g / (1 + %g s) * exp(-s * %g)\n", loop.gain, loop.time_constant_s,
          loop.delay_s);
  if (!m.has_crossover) {
    s += "|K| <= 1: |G(j w)| < 1 at every frequency, no gain crossover: the continuous loop is "
         "stable for every delay\n";
  } else {
    appendf(&s, "gain crossover      omega_g = %.3f rad/s\n", m.crossover_rad_s);
    appendf(&s, "phase margin        %.1f deg without delay, %.1f deg at tau = %g s\n",
            m.phase_margin_deg, m.phase_margin_at_delay_deg, loop.delay_s);
    appendf(&s, "largest delay       tau_max = %.3f s (continuous)\n", m.tau_max_s);
  }
  if (loop.delay_s > 0) {
    appendf(&s, "gain margin         %.2f dB at %.3f rad/s\n", m.gain_margin_db,
            m.phase_crossover_rad_s);
  }
  if (fps > 0) {
    appendf(&s,
            "sampled at %g Hz    tau_max = %.3f s; at tau = %g s the largest pole is %.4f (%s)\n",
            fps, f.sampled_tau_max_s, loop.delay_s, f.sampled.spectral_radius,
            f.sampled.stable ? "stable" : "unstable");
  }
  appendf(&s, "at tau = %g s the continuous loop is %s\n", loop.delay_s,
          m.stable ? "stable" : "unstable");
  const TrackMargins& tm = f.track_margins;
  appendf(&s,
          "\ntrack mode (the default; lead %g s, Tv %g s): the image feeds back only through rig "
          "model error, g rad of measured target angle per rad of camera angle;\n"
          "  stable for every delay while |g| < %.3f (peak |P F| = %.3f); at tau = %g s: "
          "-%.3f < g < %.3f\n",
          f.track.lead_s, f.track.rate_filter_s, tm.g_max_any_delay, tm.peak_gain, loop.delay_s,
          tm.g_max_negative, tm.g_max_positive);
  if (!f.smith.empty()) {
    appendf(&s,
            "\nsmith mode (Smith predictor, model K, T, tau = plant's nominal), tau = %g s, %g "
            "Hz;\nstep responses with the real plant off from the model:\n"
            "  plant K   plant T   plant tau   overshoot   settling (5 %%)   final error   "
            "decays\n",
            loop.delay_s, fps);
    for (const auto& c : f.smith) {
      appendf(&s, "  x%-7.2f x%-7.2f x%-9.2f %7.1f %%   %10.2f s   %11.4f   %s\n", c.k_scale,
              c.t_scale, c.tau_scale, 100 * c.f.overshoot, c.f.settling_time_s, c.f.final_error,
              c.f.decays ? "yes" : "NO");
    }
  }
  return s;
}

std::string stabilityJson(const StabilityFigures& f) {
  const LoopParams& loop = f.loop;
  const ContinuousMargins& m = f.margins;
  const bool sampled = f.frame_rate_hz > 0;
  std::ostringstream j;
  j << "{\n  \"gain\": " << num(loop.gain)
    << ",\n  \"time_constant_s\": " << num(loop.time_constant_s)
    << ",\n  \"delay_s\": " << num(loop.delay_s)
    << ",\n  \"has_crossover\": " << boolean(m.has_crossover)
    << ",\n  \"crossover_rad_s\": " << num(m.crossover_rad_s)
    << ",\n  \"phase_margin_deg\": " << num(m.phase_margin_deg)
    << ",\n  \"phase_margin_at_delay_deg\": " << num(m.phase_margin_at_delay_deg)
    << ",\n  \"gain_margin_db\": " << num(m.gain_margin_db)
    << ",\n  \"tau_max_s\": " << num(m.tau_max_s) << ",\n  \"stable\": " << boolean(m.stable)
    << ",\n  \"frame_rate_hz\": " << num(f.frame_rate_hz)
    << ",\n  \"sampled_tau_max_s\": " << (sampled ? num(f.sampled_tau_max_s) : "null")
    << ",\n  \"sampled_spectral_radius\": " << (sampled ? num(f.sampled.spectral_radius) : "null")
    << ",\n  \"sampled_stable\": " << (sampled ? boolean(f.sampled.stable) : "null")
    << ",\n  \"track_g_max_any_delay\": " << num(f.track_margins.g_max_any_delay)
    << ",\n  \"track_g_max_positive\": " << num(f.track_margins.g_max_positive)
    << ",\n  \"track_g_max_negative\": " << num(f.track_margins.g_max_negative);
  if (!f.smith.empty()) {
    j << ",\n  \"smith\": [";
    for (size_t i = 0; i < f.smith.size(); ++i) {
      const SmithCase& c = f.smith[i];
      j << (i ? ",\n    " : "\n    ") << "{\"plant_gain_scale\": " << num(c.k_scale)
        << ", \"plant_time_constant_scale\": " << num(c.t_scale)
        << ", \"plant_delay_scale\": " << num(c.tau_scale)
        << ", \"overshoot\": " << num(c.f.overshoot)
        << ", \"settling_time_s\": " << num(c.f.settling_time_s)
        << ", \"final_error\": " << num(c.f.final_error) << ", \"decays\": " << boolean(c.f.decays)
        << "}";
    }
    j << "\n  ]";
  }
  j << "\n}\n";
  return j.str();
}

}  // namespace ptz::control
