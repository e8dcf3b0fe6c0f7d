// ptz-stability's plots with gnuplot: bode.png, nyquist.png and step.png of the loop, and
// smith_step.png of the smith mode's sensitivity (the data files and scripts beside them).
#pragma once

#include <string>
#include <vector>

#include "control/stability/stability.hpp"
#include "control/stability/stability_report.hpp"

namespace ptz::control {

// Writes the data files and a gnuplot script into dir, runs gnuplot; false if it failed.
bool plotLoop(const std::string& dir, const LoopParams& loop, const ContinuousMargins& m,
              double tau_max_sampled);
// The same for the smith mode's step responses (the corners of the +-30 % box and the delay
// errors).
bool plotSmith(const std::string& dir, const std::vector<SmithCase>& cases, double delay_s,
               double fps);

}  // namespace ptz::control
