// The live delay monitor of ptz-control: the delay of every setpoint (frame capture -> setpoint
// publish, plus the plant's own dead time from the config) and the phase margin that the p99
// delay leaves to the paper's loop model K / (1 + T s) e^(-s tau) (stability.hpp).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "control/stability/stability.hpp"

namespace ptz::control {

class DelayMonitor {
 public:
  // model: the loop (its delay is ignored); plant_dead_time_s is added to every measurement.
  // smith_model_delay_s: the delay the smith mode's model assumes, checked against the measured
  // one instead of the paper loop's margin (< 0: not the smith mode).
  DelayMonitor(const LoopParams& model, double plant_dead_time_s, double min_phase_margin_deg,
               double smith_model_delay_s = -1);

  // One setpoint's measured delay, s (capture -> publish). Implausible values (negative, or
  // over a minute: lockstep's sim time) are ignored.
  void add(double measured_delay_s);
  size_t samples() const { return delays_s_.size(); }

  struct Report {
    double delay_ms_p50 = 0, delay_ms_p99 = 0;  // total: measured + plant dead time
    double phase_margin_deg = 0;                // at the p99 delay
    bool below_threshold = false;
  };
  // Over the samples since the last report; clears them.
  Report report();

  // What the process status says of the delay.
  struct Status {
    // delay_us_p50, delay_us_p99, phase_margin_millideg; smith mode: smith_delay_error_us
    // (measured - modelled delay).
    std::vector<std::pair<std::string, int64_t>> counters;
    std::string warning;  // empty: the delay is fine
  };
  static constexpr size_t kSamplesPerStatus = 30;
  // add(), and every kSamplesPerStatus samples the status of the delay (report()).
  std::optional<Status> feed(double measured_delay_s);

 private:
  LoopParams model_;
  double plant_dead_time_s_;
  double min_phase_margin_deg_;
  double smith_model_delay_s_;
  std::vector<double> delays_s_;
};

}  // namespace ptz::control
