// Stability of the default `track` controller. It aims from the 3D position in the head frame,
// so with a right rig model the image does not feed back at all. A wrong rig model closes a
// loop: the measured target angle then moves by g rad per rad of camera angle (e.g. a pan
// encoder whose scale is off by 5 % gives g = 0.05; an error that makes the target seem to move
// with the camera is g > 0). Per axis, with P = e^(-s tau) / (1 + T s) the motor and
// F = 1 + lead s / (1 + Tv s) the controller's feed-forward:
//   theta = P F (theta* + g theta)   =>   characteristic equation 1 - g P(s) F(s) = 0.
// Since |e^(-j w tau)| = 1, the loop is stable for every delay when |g| sup_w |P F| < 1.
#pragma once

#include <vector>

namespace ptz::control {

struct TrackLoopParams {
  double time_constant_s = 0.24;  // T of the motor (gain 1)
  double lead_s = 0.25;           // the track mode's feed-forward horizon (as ptz-control's)
  double rate_filter_s = 0.25;    // Tv of its rate estimate
  double delay_s = 0.0;           // tau
};

struct TrackMargins {
  double peak_gain = 0;        // sup over w of |P F|
  double g_max_any_delay = 0;  // 1 / peak_gain: stable for every delay below this |g|
  double g_max_positive = 0;   // at this delay: the largest g > 0 that is stable
  double g_max_negative = 0;   // at this delay: the largest |g| with g < 0 that is stable
};
TrackMargins trackLoopMargins(const TrackLoopParams& loop);

// Time response of the continuous track loop with image feedback g to a unit step of theta*
// (fine steps, exact delay line): for checking the margins.
std::vector<double> trackStepResponse(const TrackLoopParams& loop, double g, double duration_s,
                                      double step_s);

}  // namespace ptz::control
