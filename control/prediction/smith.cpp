#include "control/prediction/smith.hpp"

#include <algorithm>
#include <cmath>

namespace ptz::control {

namespace {
constexpr double kModelStepS = 0.001;
}

SmithPredictor::SmithPredictor(SmithParams params) : p_(std::move(params)) {}

void SmithPredictor::reset(double t_s, double position) {
  AxisParams undelayed = p_.model;
  undelayed.dead_time_s = 0;
  model_.emplace(undelayed, position);
  t0_s_ = t_s;
  last_t_s_ = t_s;
  history_.assign(1, {0.0, model_->position()});
  correction_ = 0;
}

double SmithPredictor::modelAt(double t_s) const {
  const double t = t_s - t0_s_;
  if (t <= history_.front().first) return history_.front().second;
  auto it = std::lower_bound(history_.begin(), history_.end(), t,
                             [](const auto& sample, double time) { return sample.first < time; });
  if (it == history_.end()) return history_.back().second;
  const auto& [t1, y1] = *it;
  const auto& [t0, y0] = *std::prev(it);
  return t1 > t0 ? y0 + (y1 - y0) * (t - t0) / (t1 - t0) : y1;
}

void SmithPredictor::advance(double t_s) {
  if (t_s <= last_t_s_) return;
  model_->advanceTo(t_s - t0_s_, kModelStepS);
  last_t_s_ = t_s;
  history_.emplace_back(t_s - t0_s_, model_->position());
  // Keep what the delay needs, and a second more.
  const double keep_from = t_s - t0_s_ - p_.model.dead_time_s - 1.0;
  while (history_.size() > 2 && history_[1].first < keep_from) history_.pop_front();
}

double SmithPredictor::correction(double t_s, double measured_at_capture, double capture_t_s) {
  if (!model_ || t_s < last_t_s_) reset(t_s, measured_at_capture);
  const double dt = t_s - last_t_s_;
  advance(t_s);
  const double d = measured_at_capture - modelAt(capture_t_s - p_.model.dead_time_s);
  const double tf = p_.correction_filter_s;
  correction_ += (tf > 0 ? 1.0 - std::exp(-dt / tf) : 1.0) * (d - correction_);
  return correction_;
}

double SmithPredictor::command(double t_s, double reference, double reference_rate,
                               double measured_at_capture, double capture_t_s) {
  const double d = correction(t_s, measured_at_capture, capture_t_s);
  return (reference - d + p_.model.time_constant_s * reference_rate) / p_.model.gain;
}

void SmithPredictor::sent(double t_s, double command_sent) {
  if (!model_ || t_s < last_t_s_) return;
  advance(t_s);
  model_->command(t_s - t0_s_, command_sent);
}

}  // namespace ptz::control

namespace ptz::control {

std::vector<double> smithStepResponse(const AxisParams& plant, const SmithParams& smith,
                                      double frame_rate_hz, double duration_s) {
  AxisParams p = plant;
  p.min_position = -1e9;  // the linear loop: no limits within reach
  p.max_position = 1e9;
  p.max_rate_per_s = 1e9;
  SmithParams s = smith;
  s.model.min_position = p.min_position;
  s.model.max_position = p.max_position;
  s.model.max_rate_per_s = p.max_rate_per_s;
  Pt1Axis axis(p, 0.0);
  SmithPredictor predictor(s);
  predictor.reset(0.0, 0.0);
  const double frame_s = 1.0 / frame_rate_hz;
  const int frames = static_cast<int>(std::lround(duration_s * frame_rate_hz));
  std::vector<double> response;
  response.reserve(static_cast<size_t>(frames));
  for (int k = 0; k < frames; ++k) {
    const double t = k * frame_s;
    axis.advanceTo(t, 1e-3);
    response.push_back(axis.position());
    const double u = predictor.command(t, 1.0, 0.0, axis.position(), t);
    predictor.sent(t, u);
    axis.command(t, u);
  }
  return response;
}

StepFigures stepFigures(const std::vector<double>& y, double frame_rate_hz) {
  StepFigures f;
  if (y.empty()) return f;
  double peak = 0, early = 0, late = 0;
  size_t last_outside = 0;
  for (size_t k = 0; k < y.size(); ++k) {
    peak = std::max(peak, y[k]);
    const double dev = std::abs(y[k] - 1.0);
    if (dev > 0.05) last_outside = k + 1;
    if (k >= y.size() / 4 && k < y.size() / 2) early = std::max(early, dev);
    if (k >= 3 * y.size() / 4) late = std::max(late, dev);
  }
  f.overshoot = std::max(0.0, peak - 1.0);
  f.settling_time_s = last_outside >= y.size() ? INFINITY : last_outside / frame_rate_hz;
  f.final_error = std::abs(1.0 - y.back());
  f.decays = late < early || late < 1e-3;
  return f;
}

}  // namespace ptz::control
