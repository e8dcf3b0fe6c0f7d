// How far a measured zoom map (zoom units -> ratio) is from the true one, as the focal length the
// rig gives each: the largest relative error over [from, to] in steps, each checked within 2 %.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "common/rig.hpp"

namespace ptz::test {

template <class Truth, class Measured>
double worstFocalLengthError(const ptz::StereoRig& rig, double from, double to, double step,
                             const Truth& truth, const Measured& measured) {
  double worst = 0;
  for (double u = from; u <= to + step / 2; u += step) {
    const double f_true = rig.left.intrinsicsAt(truth(u)).fx;
    const double f_measured = rig.left.intrinsicsAt(measured(u)).fx;
    EXPECT_NEAR(f_measured / f_true, 1, 0.02) << "at zoom " << u;
    worst = std::max(worst, std::abs(f_measured / f_true - 1));
  }
  return worst;
}

}  // namespace ptz::test
