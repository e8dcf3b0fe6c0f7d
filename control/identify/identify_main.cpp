// ptz-identify: fits K, T and tau of one axis from an LCM log of a step test (PTZ_SETPOINT and
// PTZ_STATE) and prints the margins the paper's loop would have with that plant. A missing,
// empty or foreign log, or one without those channels, has its own exit code
// (tools/logs/log_reader.hpp); a damaged log is fitted as far as it reads, with a warning. The
// record, the fit and its report are the library's (step_test.hpp, identify.hpp).
#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "control/identify/step_test.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "tools/logs/log_reader.hpp"

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
    const std::optional<ptz::control::AxisName> axis_name = ptz::control::parseAxisName(axis);
    if (!axis_name) {
      throw p.invalid(
          "axis", "must be left_pan, left_tilt, left_zoom, right_pan, right_tilt or right_zoom");
    }
    const std::string path = p.getString("log");
    if (path.empty()) throw ptz::ConfigError("--log FILE is required");
    ptz::tools::LogReader log(path);
    const std::string prefix = p.getString("channel_prefix");
    std::vector<ptzstereo::ptz_state_t> states;
    std::vector<ptzstereo::ptz_setpoint_t> setpoints;
    while (const lcm::LogEvent* ev = log.next()) {
      if (ev->channel == prefix + "PTZ_STATE") {
        ptzstereo::ptz_state_t s;
        if (s.decode(ev->data, 0, ev->datalen) >= 0) states.push_back(s);
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
    const ptz::control::StepTest test = ptz::control::stepTestOf(states, setpoints, *axis_name);
    const ptz::control::AxisFit fit = ptz::control::identifyAxis(test.record);
    if (!fit.ok) {
      std::fprintf(stderr, "ptz-identify: %s: %s\n", path.c_str(), fit.error.c_str());
      return ptz::tools::log_exit::kVerdict;
    }
    std::fputs(ptz::control::fitReport(axis, test, fit, p.getDouble("paper_gain")).c_str(), stdout);
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
