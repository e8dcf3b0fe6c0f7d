// A Smith predictor for one axis (pan or tilt of one head), in its internal-model-control form.
// The shared PT1 plant model, run without its dead time on the commands actually sent, predicts
// where the axis will be when a command issued now takes effect; what the model got wrong shows
// as d = y_measured(t_c) - y_model(t_c - tau), the measured angle at capture minus the model's
// delayed output. The command inverts the model for the predicted reference r, less d:
//   u = (r - d_f + T r') / K,   d_f = d through a first-order filter (correction_filter_s)
// With a right model d = 0 and the axis follows r exactly (no feedback, no delay in the loop);
// with a wrong one the loop closes only through d: u = -Q (G - Gm) e^(-s tau) u with
// Q = (1 + T s) / (K (1 + Tf s)), so by the small-gain theorem it stays stable whatever the
// delay as long as |G - Gm| / |Gm| < 1 at every frequency (K and T off by 30 %: at most 0.3,
// and the filter only lowers it), and the model's delay is right. Zero steady-state error:
// in steady state d is exactly the gain error.
#pragma once

#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "common/plant.hpp"

namespace ptz::control {

struct SmithParams {
  AxisParams model;                  // K, T, limits; its dead_time_s is the delay tau_m of the loop
  double correction_filter_s = 0.1;  // Tf: smooths d (measurement noise on the angles)
};

class SmithPredictor {
 public:
  explicit SmithPredictor(SmithParams params);

  // Starts the model at the measured position, at t_s.
  void reset(double t_s, double position);
  bool started() const { return model_.has_value(); }
  // The model's error d seen in the measurement at capture, filtered.
  double correction(double t_s, double measured_at_capture, double capture_t_s);
  // The command for reference r (and its rate) at t_s; call sent() with what was really sent.
  double command(double t_s, double reference, double reference_rate, double measured_at_capture,
                 double capture_t_s);
  // The command sent at t_s after limits and slew: what the model integrates.
  void sent(double t_s, double command_sent);
  double delayS() const { return p_.model.dead_time_s; }

 private:
  void advance(double t_s);          // the model up to t_s, recorded
  double modelAt(double t_s) const;  // the delay-free model's output at a past time

  SmithParams p_;
  std::optional<Pt1Axis> model_;  // no dead time; time counted from t0_s_
  double t0_s_ = 0;
  std::deque<std::pair<double, double>> history_;  // (t - t0, model output)
  double correction_ = 0, last_t_s_ = 0;
};

}  // namespace ptz::control

namespace ptz::control {

// The sampled Smith loop of one axis against the shared plant model (exact PT1 + dead time):
// a unit step of the reference at t = 0, one measurement and one command per frame. The plant
// may differ from the predictor's model: this is how the sensitivity to a wrong model is shown.
std::vector<double> smithStepResponse(const AxisParams& plant, const SmithParams& smith,
                                      double frame_rate_hz, double duration_s);

struct StepFigures {
  double overshoot = 0;        // peak above 1, fraction of the step
  double settling_time_s = 0;  // last time outside +-5 % (infinite when never settled)
  double final_error = 0;      // |1 - y| at the end
  bool decays = false;         // late oscillation smaller than early
};
StepFigures stepFigures(const std::vector<double>& response, double frame_rate_hz);

}  // namespace ptz::control
