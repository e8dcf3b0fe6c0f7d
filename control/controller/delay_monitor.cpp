#include "control/controller/delay_monitor.hpp"

#include <algorithm>
#include <cmath>

namespace ptz::control {

DelayMonitor::DelayMonitor(const LoopParams& model, double plant_dead_time_s,
                           double min_phase_margin_deg)
    : model_(model),
      plant_dead_time_s_(plant_dead_time_s),
      min_phase_margin_deg_(min_phase_margin_deg) {}

void DelayMonitor::add(double measured_delay_s) {
  if (!(measured_delay_s >= 0) || measured_delay_s > 60) return;
  delays_s_.push_back(measured_delay_s + plant_dead_time_s_);
}

DelayMonitor::Report DelayMonitor::report() {
  Report r;
  if (delays_s_.empty()) return r;
  std::sort(delays_s_.begin(), delays_s_.end());
  auto at = [&](double p) {
    return delays_s_[std::min(delays_s_.size() - 1,
                              static_cast<size_t>(std::ceil(p / 100 * delays_s_.size())) - 1)];
  };
  r.delay_ms_p50 = at(50) * 1000;
  r.delay_ms_p99 = at(99) * 1000;
  LoopParams l = model_;
  l.delay_s = at(99);
  r.phase_margin_deg = continuousMargins(l).phase_margin_at_delay_deg;
  r.below_threshold = r.phase_margin_deg < min_phase_margin_deg_;
  delays_s_.clear();
  return r;
}

}  // namespace ptz::control
