// What ptz-stability reports of one loop: every figure (continuous and sampled margins, the track
// mode's bound, optionally the smith mode's sensitivity to a wrong plant model), as the text it
// prints and as JSON. The plots are stability_plots.hpp's.
#pragma once

#include <string>
#include <vector>

#include "control/prediction/smith.hpp"
#include "control/stability/stability.hpp"
#include "control/stability/track_analysis.hpp"

namespace ptz::control {

// The Smith loop's step response for a plant off from its model by these factors.
struct SmithCase {
  double k_scale, t_scale, tau_scale;
  std::vector<double> y;
  StepFigures f;
};
// The sensitivity table: K and T off by 30 % (3 x 3), then the delay alone off (0.8 .. 2).
std::vector<SmithCase> smithSensitivity(double motor_gain, double time_constant_s, double delay_s,
                                        double frame_rate_hz);

struct StabilityFigures {
  LoopParams loop;
  double frame_rate_hz = 0;  // 0: continuous only
  ContinuousMargins margins;
  double sampled_tau_max_s = 0;  // NaN without a frame rate
  SampledResult sampled;
  TrackLoopParams track;
  TrackMargins track_margins;
  std::vector<SmithCase> smith;  // empty unless asked for
};

// smith_motor_gain > 0: also the smith mode's sensitivity (needs a frame rate).
StabilityFigures analyseStability(const LoopParams& loop, double frame_rate_hz,
                                  const TrackLoopParams& track, double smith_motor_gain);
// What ptz-stability prints.
std::string stabilityText(const StabilityFigures& f);
// Every figure as one JSON object (infinite values as null).
std::string stabilityJson(const StabilityFigures& f);

}  // namespace ptz::control
