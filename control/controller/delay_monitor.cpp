#include "control/controller/delay_monitor.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ptz::control {

namespace {

std::string millis(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", v);
  return text;
}

}  // namespace

DelayMonitor::DelayMonitor(const LoopParams& model, double plant_dead_time_s,
                           double min_phase_margin_deg, double smith_model_delay_s)
    : model_(model),
      plant_dead_time_s_(plant_dead_time_s),
      min_phase_margin_deg_(min_phase_margin_deg),
      smith_model_delay_s_(smith_model_delay_s) {}

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

std::optional<DelayMonitor::Status> DelayMonitor::feed(double measured_delay_s) {
  add(measured_delay_s);
  if (samples() < kSamplesPerStatus) return std::nullopt;
  const Report r = report();
  Status s;
  s.counters = {{"delay_us_p50", std::llround(r.delay_ms_p50 * 1000)},
                {"delay_us_p99", std::llround(r.delay_ms_p99 * 1000)},
                {"phase_margin_millideg", std::llround(r.phase_margin_deg * 1000)}};
  if (smith_model_delay_s_ >= 0) {
    // The paper loop's margin means nothing to the Smith predictor; a wrong model delay does.
    const double error_s = r.delay_ms_p50 / 1000 - smith_model_delay_s_;
    s.counters.emplace_back("smith_delay_error_us", std::llround(error_s * 1e6));
    if (std::abs(error_s) > std::max(0.1 * smith_model_delay_s_, 0.01)) {
      s.warning = "measured delay p50 " + millis(r.delay_ms_p50) + " ms, the smith model assumes " +
                  millis(smith_model_delay_s_ * 1000) + " ms: set smith_extra_delay_s";
    }
  } else if (r.below_threshold) {
    s.warning = "delay p99 " + millis(r.delay_ms_p99) + " ms leaves a phase margin of " +
                millis(r.phase_margin_deg) + " deg";
  }
  return s;
}

}  // namespace ptz::control
