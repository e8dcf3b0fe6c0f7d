// The full-orientation filter of tagged tracks against known rotations: noisy measurements of a
// steadily turning object are smoothed without lag (the error below the measurements'), a
// measurement far outside the gate is refused, three refusals in a row restart it, and what is not
// a rotation is ignored.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "perception/tracking/rotation.hpp"

namespace perception = ptz::perception;

namespace {

double angleDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::AngleAxisd(a.conjugate() * b).angle() * 180 / M_PI;
}

Eigen::Quaterniond turn(const Eigen::Vector3d& v) {
  return v.norm() < 1e-15 ? Eigen::Quaterniond::Identity()
                          : Eigen::Quaterniond(Eigen::AngleAxisd(v.norm(), v.normalized()));
}

}  // namespace

TEST(RotationFilter, SmoothsATurningObjectsNoise) {
  perception::RotationFilterParams p;
  perception::RotationEstimate e;
  std::mt19937 rng(4);
  // A tag squarely facing the cameras at a few metres (test_markers.cpp).
  const double sigma_rad = 2.0 * M_PI / 180;
  std::normal_distribution<double> noise(0, sigma_rad);
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity() * sigma_rad * sigma_rad;
  double sum2_measured = 0, sum2_filtered = 0;
  int n = 0;
  for (int k = 0; k < 300; ++k) {
    const double t = k / 30.0;
    // 0.45 rad/s about a tilted axis, as the tagged box of the scenario.
    const Eigen::Quaterniond truth =
        turn(Eigen::Vector3d(0.1, 1, 0).normalized() * 0.45 * t) * turn({0.15, 0, 0});
    const Eigen::Quaterniond measured = turn({noise(rng), noise(rng), noise(rng)}) * truth;
    const auto u = perception::updateRotation(&e, t, measured, R, p);
    ASSERT_NE(u, perception::RotationUpdate::kRefused) << k;
    if (k >= 30) {
      sum2_measured += std::pow(angleDeg(measured, truth), 2);
      sum2_filtered += std::pow(angleDeg(e.rotation, truth), 2);
      ++n;
    }
  }
  const double measured_rms = std::sqrt(sum2_measured / n);
  const double filtered_rms = std::sqrt(sum2_filtered / n);
  std::printf("measured %.3f deg RMS, filtered %.3f deg RMS\n", measured_rms, filtered_rms);
  EXPECT_LT(filtered_rms, 0.7 * measured_rms);  // 0.64 with the default noise
}

TEST(RotationFilter, RefusesAWildMeasurementAndRestartsAfterThree) {
  perception::RotationFilterParams p;
  perception::RotationEstimate e;
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity() * 1e-4;
  EXPECT_EQ(perception::updateRotation(&e, 0, Eigen::Quaterniond::Identity(), R, p),
            perception::RotationUpdate::kStarted);
  EXPECT_EQ(perception::updateRotation(&e, 0.033, Eigen::Quaterniond::Identity(), R, p),
            perception::RotationUpdate::kAccepted);
  const Eigen::Quaterniond flipped = turn({0, M_PI / 2, 0});
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(perception::updateRotation(&e, 0.066 + 0.033 * k, flipped, R, p),
              perception::RotationUpdate::kRefused);
    EXPECT_LT(angleDeg(e.rotation, Eigen::Quaterniond::Identity()), 1e-9);
  }
  EXPECT_EQ(perception::updateRotation(&e, 0.2, flipped, R, p),
            perception::RotationUpdate::kStarted);
  EXPECT_LT(angleDeg(e.rotation, flipped), 1e-9);
  // Not a rotation: ignored.
  EXPECT_EQ(perception::updateRotation(&e, 0.25, Eigen::Quaterniond(2, 0, 0, 0), R, p),
            perception::RotationUpdate::kInvalid);
  EXPECT_EQ(perception::updateRotation(&e, 0.25, flipped, Eigen::Matrix3d::Zero(), p),
            perception::RotationUpdate::kInvalid);
  EXPECT_EQ(perception::updateRotation(&e, 0.25, Eigen::Quaterniond(NAN, 0, 0, 0), R, p),
            perception::RotationUpdate::kInvalid);
}
