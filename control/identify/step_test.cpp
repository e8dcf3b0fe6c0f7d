#include "control/identify/step_test.hpp"

#include <cmath>
#include <cstdio>

#include "control/stability/stability.hpp"

namespace ptz::control {
namespace {

template <class Head>
double pick(const Head& h, const std::string& what) {
  return what == "pan" ? h.pan_rad : what == "tilt" ? h.tilt_rad : h.zoom;
}

// Lockstep states carry sim time, far from the wall clock they were published at.
constexpr int64_t kClocksApartUs = 10'000'000;

}  // namespace

std::optional<AxisName> parseAxisName(const std::string& name) {
  const auto sep = name.find('_');
  if (sep == std::string::npos) return std::nullopt;
  const std::string side = name.substr(0, sep), what = name.substr(sep + 1);
  if ((side != "left" && side != "right") || (what != "pan" && what != "tilt" && what != "zoom")) {
    return std::nullopt;
  }
  return AxisName{side == "left", what};
}

StepTest stepTestOf(const std::vector<ptzstereo::ptz_state_t>& states,
                    const std::vector<ptzstereo::ptz_setpoint_t>& setpoints, const AxisName& axis) {
  StepTest t;
  for (const auto& s : states) {
    t.lockstep |= std::abs(s.publish_utime - s.utime) > kClocksApartUs;
    t.record.positions.emplace_back(s.utime * 1e-6, pick(axis.left ? s.left : s.right, axis.what));
  }
  for (const auto& s : setpoints) {
    t.record.setpoints.emplace_back((t.lockstep ? s.utime : s.publish_utime) * 1e-6,
                                    pick(axis.left ? s.left : s.right, axis.what));
  }
  return t;
}

std::string fitReport(const std::string& axis_name, const StepTest& test, const AxisFit& fit,
                      double paper_gain) {
  char line[512];
  std::string s;
  std::snprintf(line, sizeof(line), "%s from %zu states and %zu setpoints (%s clock):\n",
                axis_name.c_str(), test.record.positions.size(), test.record.setpoints.size(),
                test.lockstep ? "lockstep" : "real-time");
  s += line;
  std::snprintf(line, sizeof(line),
                "  K = %.4f   T = %.4f s   tau = %.4f s   (rms residual %.2e)\n", fit.gain,
                fit.time_constant_s, fit.dead_time_s, fit.rms_residual);
  s += line;
  const auto m = continuousMargins({paper_gain * fit.gain, fit.time_constant_s, fit.dead_time_s});
  if (m.has_crossover) {
    std::snprintf(line, sizeof(line),
                  "  with a P element of %g: omega_g = %.3f rad/s, phase margin %.1f deg (%.1f "
                  "deg at this tau), tau_max = %.3f s\n",
                  paper_gain, m.crossover_rad_s, m.phase_margin_deg, m.phase_margin_at_delay_deg,
                  m.tau_max_s);
  } else {
    std::snprintf(line, sizeof(line),
                  "  with a P element of %g the loop gain is <= 1: stable for any delay\n",
                  paper_gain);
  }
  return s + line;
}

}  // namespace ptz::control
