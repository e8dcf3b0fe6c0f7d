// ptz-identify: fits K, T and tau of one axis from an LCM log of a step test (PTZ_SETPOINT and
// PTZ_STATE) and prints the margins the paper's loop would have with that plant. A missing,
// empty or foreign log, or one without those channels, has its own exit code
// (tools/logs/log_reader.hpp); a damaged log is fitted as far as it reads, with a warning.
#include <lcm/lcm-cpp.hpp>

#include <cmath>
#include <cstdio>
#include <string>

#include "common/config.hpp"
#include "control/identify/identify.hpp"
#include "control/stability/stability.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "tools/logs/log_reader.hpp"

namespace {

double pick(const ptzstereo::ptz_head_state_t& h, const std::string& what) {
  return what == "pan" ? h.pan_rad : what == "tilt" ? h.tilt_rad : h.zoom;
}
double pick(const ptzstereo::ptz_head_setpoint_t& h, const std::string& what) {
  return what == "pan" ? h.pan_rad : what == "tilt" ? h.tilt_rad : h.zoom;
}

}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz-identify",
                "Fits gain K, time constant T and dead time tau of one PTZ axis to a step test "
                "recorded with lcm-logger (PTZ_SETPOINT and PTZ_STATE), and prints the margins of "
                "the paper's loop with that plant.\n" +
                    ptz::tools::logExitCodesHelp("the fit failed (no step of the axis in the "
                                                 "log, or the model does not fit)"));
  p.add("log", "", "the LCM log (required)");
  p.add("axis", "left_pan", "left_pan, left_tilt, left_zoom, right_pan, right_tilt, right_zoom");
  p.add("paper_gain", 1.7, "", "P gain of the loop whose margins are printed",
        ptz::Range::above(0));
  p.add("channel_prefix", "", "prefix of the channel names");
  try {
    if (!p.parse(argc, argv)) return ptz::tools::log_exit::kOk;
    const std::string axis = p.getString("axis");
    const auto sep = axis.find('_');
    const std::string side = axis.substr(0, sep),
                      what = sep == std::string::npos ? "" : axis.substr(sep + 1);
    if ((side != "left" && side != "right") ||
        (what != "pan" && what != "tilt" && what != "zoom")) {
      throw p.invalid(
          "axis", "must be left_pan, left_tilt, left_zoom, right_pan, right_tilt or right_zoom");
    }
    const std::string path = p.getString("log");
    if (path.empty()) throw ptz::ConfigError("--log FILE is required");
    ptz::tools::LogReader log(path);
    const std::string prefix = p.getString("channel_prefix");
    ptz::control::AxisRecord record;
    std::vector<ptzstereo::ptz_setpoint_t> setpoints;
    bool lockstep = false;
    while (const lcm::LogEvent* ev = log.next()) {
      if (ev->channel == prefix + "PTZ_STATE") {
        ptzstereo::ptz_state_t s;
        if (s.decode(ev->data, 0, ev->datalen) < 0) continue;
        // Lockstep states carry sim time, far from the wall clock they were published at.
        lockstep |= std::abs(s.publish_utime - s.utime) > 10'000'000;
        record.positions.emplace_back(s.utime * 1e-6,
                                      pick(side == "left" ? s.left : s.right, what));
      } else if (ev->channel == prefix + "PTZ_SETPOINT") {
        ptzstereo::ptz_setpoint_t s;
        if (s.decode(ev->data, 0, ev->datalen) >= 0) setpoints.push_back(s);
      }
    }
    log.requireEvents();
    log.requireChannels({prefix + "PTZ_STATE", prefix + "PTZ_SETPOINT"});
    if (!log.breaks().empty()) {
      std::fprintf(stderr,
                   "ptz-identify: warning: the log is damaged; fitted what could be "
                   "read:\n%s",
                   log.describeBreaks().c_str());
    }
    // A setpoint acts from when it was issued: in lockstep at the frame time it names, in real
    // time when it was published.
    for (const auto& s : setpoints) {
      record.setpoints.emplace_back((lockstep ? s.utime : s.publish_utime) * 1e-6,
                                    pick(side == "left" ? s.left : s.right, what));
    }
    const ptz::control::AxisFit fit = ptz::control::identifyAxis(record);
    if (!fit.ok) {
      std::fprintf(stderr, "ptz-identify: %s: %s\n", path.c_str(), fit.error.c_str());
      return ptz::tools::log_exit::kVerdict;
    }
    std::printf("%s from %zu states and %zu setpoints (%s clock):\n", axis.c_str(),
                record.positions.size(), record.setpoints.size(),
                lockstep ? "lockstep" : "real-time");
    std::printf("  K = %.4f   T = %.4f s   tau = %.4f s   (rms residual %.2e)\n", fit.gain,
                fit.time_constant_s, fit.dead_time_s, fit.rms_residual);
    const auto m = ptz::control::continuousMargins(
        {p.getDouble("paper_gain") * fit.gain, fit.time_constant_s, fit.dead_time_s});
    if (m.has_crossover) {
      std::printf(
          "  with a P element of %g: omega_g = %.3f rad/s, phase margin %.1f deg (%.1f deg "
          "at this tau), tau_max = %.3f s\n",
          p.getDouble("paper_gain"), m.crossover_rad_s, m.phase_margin_deg,
          m.phase_margin_at_delay_deg, m.tau_max_s);
    } else {
      std::printf("  with a P element of %g the loop gain is <= 1: stable for any delay\n",
                  p.getDouble("paper_gain"));
    }
    return ptz::tools::log_exit::kOk;
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-identify: %s\n", e.what());
    return ptz::tools::log_exit::kUsage;
  } catch (const ptz::tools::LogError& e) {
    std::fprintf(stderr, "ptz-identify: %s\n", e.what());
    return e.exitCode();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptz-identify: stopped: %s\n", e.what());
    return ptz::tools::log_exit::kFailed;
  }
}
