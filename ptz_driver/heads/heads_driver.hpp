// What ptz-driver does with its two heads, without LCM: a setpoint (already judged fresh by the
// main) is refused when any value is non-finite, else clamped to the axis limits; every tick
// the heads are slewed toward it, held by the deadman without a fresh one, asked where they are;
// PTZ_STATE is built from what they measured; and their counters and health are summed for the
// status.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/config.hpp"
#include "common/plant.hpp"
#include "ptz_driver/heads/common/head.hpp"
#include "ptz_driver/heads/common/slewed_command.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"

namespace ptz::driver {

// Everything but the transport's parameters, in the order of --help.
void declareDriverParams(Params& p);

// The heads' counters and health, summed over both for the status.
struct HeadsReport {
  std::vector<std::pair<std::string, int64_t>> counters;  // head_timeouts .. position_estimated
  std::vector<double> round_trip_ms;                      // since the last report
  std::vector<std::string> head_errors;                   // each head's last error, if any
  int8_t state = 0;                                       // process_status_t::STATE_*
  std::string message;
};

class HeadsDriver {
 public:
  struct Settings {
    PtzPlant::Params limits;
    double inquiry_timeout_s = 0.1, deadman_s = 0.25, max_setpoint_rate = 3.0;
    static Settings fromParams(const Params& p);
  };
  HeadsDriver(std::array<std::unique_ptr<PtzHead>, 2> heads, const Settings& settings);

  PtzHead& head(size_t i) { return *heads_[i]; }
  void start(double now_s);
  void receive(double now_s);
  // False (nothing changes) when a value is non-finite; else both targets, clamped.
  bool acceptSetpoint(const ptzstereo::ptz_setpoint_t& m, double now_s);
  // One period: the deadman, the slewed commands, the inquiries. True when the deadman began
  // holding in this tick.
  bool tick(double now_s, double period_s);
  // Both heads' newest measurement, once per new one (publish_utime is the sender's).
  std::optional<ptzstereo::ptz_state_t> newState();
  HeadsReport report(double now_s);

 private:
  Settings settings_;
  std::array<std::unique_ptr<PtzHead>, 2> heads_;
  std::array<std::optional<PtzPose>, 2> target_;  // the last fresh setpoint, until a hold
  std::array<SlewedCommand, 2> commands_;
  double last_setpoint_s_ = 0, last_state_s_ = 0;
  int64_t last_setpoint_utime_ = 0;
  bool holding_ = false;
};

}  // namespace ptz::driver
