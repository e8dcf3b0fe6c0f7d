// Stability of one axis of the loop under delay (paper, section 4): a PT1 plant K / (1 + T s)
// (motor and P element together, the paper's 1.7 / (1 + 0.24 s)) behind a dead time tau, with
// unity feedback; continuous, and sampled once per frame with the command held between frames.
#pragma once

#include <string>
#include <vector>

namespace ptz::control {

struct LoopParams {
  double gain = 1.7;              // K: the open-loop gain (controller times motor)
  double time_constant_s = 0.24;  // T
  double delay_s = 0.0;           // tau
};

struct ContinuousMargins {
  bool has_crossover = false;            // K <= 1: |G| < 1 at every frequency, no crossover
  double crossover_rad_s = 0;            // omega_g, |G*(j omega_g)| = 1 (eq. 10)
  double phase_margin_deg = 0;           // without delay (eq. 11)
  double phase_margin_at_delay_deg = 0;  // eq. 12
  double tau_max_s = 0;                  // eq. 14 (infinite without a crossover)
  double gain_margin_db = 0;             // at the delay: -20 log10 |G| where the phase is -180 deg
  double phase_crossover_rad_s = 0;      // where that is (0: none, tau = 0)
  bool stable = true;                    // at the delay
};

ContinuousMargins continuousMargins(const LoopParams& loop);

// The sampled loop: the error is measured at each frame (period 1 / frame_rate_hz), the command
// issued then and acting tau later, held until the next (ZOH). Exact discretisation of the PT1
// with a fractional delay (modified z-transform); stable when every closed-loop pole is inside
// the unit circle.
struct SampledResult {
  double spectral_radius = 0;  // the largest closed-loop pole magnitude
  bool stable = true;
};
SampledResult sampledStability(const LoopParams& loop, double frame_rate_hz);
// The largest delay for which the sampled loop is stable (bisection on tau; the first loss).
double sampledTauMax(const LoopParams& loop, double frame_rate_hz);

// Frequency response of the open loop with delay, for plots.
struct FrequencyPoint {
  double omega_rad_s, magnitude_db, phase_deg, re, im;
};
std::vector<FrequencyPoint> openLoopResponse(const LoopParams& loop, double omega_min,
                                             double omega_max, int points);

// Time response of the continuous closed loop to a unit step of the reference (fine Euler-exact
// steps of the PT1, exact delay line), for checking the boundary and for plots.
std::vector<double> continuousStepResponse(const LoopParams& loop, double duration_s,
                                           double step_s);
// Whether the continuous loop's step response decays (the oscillation's late peaks shrink).
bool continuousLoopDecays(const LoopParams& loop);

}  // namespace ptz::control
