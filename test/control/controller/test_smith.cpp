// Delay compensation: the constant-velocity and the turn Kalman filters, the Smith predictor
// against the shared plant model (right and wrong), and the controller's smith mode in a fast
// in-process loop (ideal measurements, exact PT1 + dead time) at a delay far beyond the paper's
// tau_max.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/plant.hpp"
#include "control/controller/controller.hpp"
#include "control/controller/pointing.hpp"
#include "control/prediction/kalman.hpp"
#include "control/prediction/smith.hpp"
#include "control/prediction/turn_kalman.hpp"
#include "control/stability/stability.hpp"
#include "control/stability/track_analysis.hpp"
#include "sim/scene/scene.hpp"

namespace pc = ptz::control;

TEST(Kalman, LearnsAConstantVelocityAndPredictsASecondAhead) {
  const Eigen::Vector3d p0(0.2, -0.1, 3.0), v(0.3, 0.05, -0.2);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  pc::KalmanParams params;
  params.accel_psd_m2_s3 = 1e-3;  // the target really keeps its velocity
  pc::ConstantVelocityKalman kf(params);
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity() * 1e-4;
  for (int k = 0; k <= 90; ++k) {
    const double t = 100.0 + k / 30.0;
    const Eigen::Vector3d z =
        p0 + v * (t - 100.0) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    ASSERT_TRUE(kf.update(t, z, R));
  }
  EXPECT_LT((kf.velocity() - v).norm(), 0.03);
  const double t_ahead = 104.0;  // one second after the last measurement
  EXPECT_LT((kf.positionAt(t_ahead) - (p0 + v * 4.0)).norm(), 0.04);
}

TEST(Kalman, GatesAnOutlierAndRestartsOnATargetThatReallyJumped) {
  pc::ConstantVelocityKalman kf;
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity() * 1e-4;
  const Eigen::Vector3d here(0, 0, 3), there(1, 0, 3);
  for (int k = 0; k < 30; ++k) ASSERT_TRUE(kf.update(k / 30.0, here, R));
  EXPECT_FALSE(kf.update(1.0, there, R));  // one wrong detection: ignored
  EXPECT_LT((kf.positionAt(1.0) - here).norm(), 1e-3);
  for (int k = 1; k < 4; ++k) EXPECT_FALSE(kf.update(1.0 + k / 30.0, there, R));
  kf.update(1.0 + 4 / 30.0, there, R);  // the fifth in a row: the target is there
  EXPECT_LT((kf.positionAt(1.0 + 4 / 30.0) - there).norm(), 1e-9);
}

namespace {

// Uniform circular motion in a tilted plane (the turn filter knows no preferred axis): radius
// 0.6 m at 1.5 m/s (w = 2.5 rad/s, the fast_circle scene), about the unit normal n.
struct Circle {
  Eigen::Vector3d centre{0.1, 0.2, 2.0}, n = Eigen::Vector3d(0.3, 1.0, 0.2).normalized();
  double radius_m = 0.6, w_rad_s = 2.5;
  Eigen::Vector3d position(double t) const {
    const Eigen::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
    return centre + radius_m * (std::cos(w_rad_s * t) * e1 + std::sin(w_rad_s * t) * e2);
  }
  Eigen::Vector3d velocity(double t) const { return w_rad_s * n.cross(position(t) - centre); }
};

}  // namespace

TEST(TurnKalman, ItsModelMovesExactlyAlongACircle) {
  const Circle c;
  pc::TurnKalman::State x;
  x << c.position(0.3), c.velocity(0.3), c.w_rad_s * c.n;
  for (double dt : {1e-5, 0.033, 1.0, 2.0}) {
    const pc::TurnKalman::State y = pc::TurnKalman::propagate(x, dt);
    EXPECT_LT((y.head<3>() - c.position(0.3 + dt)).norm(), 1e-9) << dt;
    EXPECT_LT((y.segment<3>(3) - c.velocity(0.3 + dt)).norm(), 1e-9) << dt;
  }
  // Without a turn: a straight line.
  x.tail<3>().setZero();
  EXPECT_LT(
      (pc::TurnKalman::propagate(x, 1.0).head<3>() - (c.position(0.3) + c.velocity(0.3))).norm(),
      1e-12);
}

TEST(TurnKalman, LearnsTheTurnOfACircleAndPredictsASecondAhead) {
  const Circle c;
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.01);  // 1 cm, as stereo at 2 m
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity() * 1e-4;
  pc::TurnKalman turn;
  pc::ConstantVelocityKalman straight;
  double sum_sq_turn = 0, sum_sq_straight = 0;
  int n = 0;
  for (int k = 0; k <= 30 * 6; ++k) {
    const double t = k / 30.0;
    const Eigen::Vector3d z = c.position(t) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    ASSERT_TRUE(turn.update(t, z, R)) << t;
    straight.update(t, z, R);
    if (t < 2.0) continue;  // after the filters settled: where they put the target 1 s later
    sum_sq_turn += (turn.positionAt(t + 1.0) - c.position(t + 1.0)).squaredNorm();
    sum_sq_straight += (straight.positionAt(t + 1.0) - c.position(t + 1.0)).squaredNorm();
    ++n;
  }
  const double rms_turn = std::sqrt(sum_sq_turn / n), rms_straight = std::sqrt(sum_sq_straight / n);
  std::printf("circle r 0.6 m at 1.5 m/s, 1 s ahead: turn %.3f m RMS, constant velocity %.3f m\n",
              rms_turn, rms_straight);
  EXPECT_LT((turn.turnRate() - c.w_rad_s * c.n).norm(), 0.05 * c.w_rad_s);
  // 1 s is 0.4 of a turn: the tangent (constant velocity) misses by about the diameter.
  EXPECT_LT(rms_turn, 0.1);
  EXPECT_GT(rms_straight, 1.0);
}

TEST(TurnKalman, GatesAnOutlierAndRestartsOnATargetThatReallyJumped) {
  pc::TurnKalman kf;
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity() * 1e-4;
  const Eigen::Vector3d here(0, 0, 3), there(1, 0, 3);
  for (int k = 0; k < 30; ++k) ASSERT_TRUE(kf.update(k / 30.0, here, R));
  EXPECT_FALSE(kf.update(1.0, there, R));
  EXPECT_LT((kf.positionAt(1.0) - here).norm(), 1e-3);
  for (int k = 1; k < 4; ++k) EXPECT_FALSE(kf.update(1.0 + k / 30.0, there, R));
  kf.update(1.0 + 4 / 30.0, there, R);
  EXPECT_LT((kf.positionAt(1.0 + 4 / 30.0) - there).norm(), 1e-9);
}

namespace {

ptz::AxisParams axis(double gain, double time_constant_s, double dead_time_s) {
  ptz::AxisParams a;
  a.gain = gain;
  a.time_constant_s = time_constant_s;
  a.dead_time_s = dead_time_s;
  return a;
}

pc::SmithParams smith(double delay_s) {
  pc::SmithParams s;
  s.model = axis(1.0, 0.24, delay_s);
  return s;
}

}  // namespace

TEST(SmithPredictor, ARightModelMakesTheDelayedLoopTheDelayFreeOne) {
  // The paper's P loop is unstable at tau = 1 s; the predictor is not, and its response is the
  // delay-free model 1 / (1 + T s) shifted by tau: no overshoot, settled (5 %) after
  // tau + T ln 20 plus at most a frame of sampling.
  ASSERT_FALSE(pc::sampledStability({1.7, 0.24, 1.0}, 30.0).stable);
  const auto y = pc::smithStepResponse(axis(1.0, 0.24, 1.0), smith(1.0), 30.0, 8.0);
  const pc::StepFigures f = pc::stepFigures(y, 30.0);
  EXPECT_TRUE(f.decays);
  EXPECT_LT(f.overshoot, 0.01);
  EXPECT_LT(f.final_error, 1e-4);
  EXPECT_NEAR(f.settling_time_s, 1.0 + 0.24 * std::log(20.0), 1.0 / 30);
}

TEST(SmithPredictor, StaysStableWithGainAndTimeConstantOffByThirtyPercent) {
  for (double tau : {0.6, 1.0}) {
    for (double k_scale : {0.7, 1.0, 1.3}) {
      for (double t_scale : {0.7, 1.0, 1.3}) {
        const auto y =
            pc::smithStepResponse(axis(k_scale, 0.24 * t_scale, tau), smith(tau), 30.0, 12.0);
        const pc::StepFigures f = pc::stepFigures(y, 30.0);
        SCOPED_TRACE("tau " + std::to_string(tau) + " K x" + std::to_string(k_scale) + " T x" +
                     std::to_string(t_scale));
        EXPECT_TRUE(f.decays);
        EXPECT_LT(f.final_error, 0.01);  // d carries the gain error: none left
        // A gain 30 % high overshoots by the 30 % the feed-forward gets wrong until the first
        // measurement of it is back, a delay later.
        EXPECT_LT(f.overshoot, k_scale > 1 ? 0.45 : 0.10);
      }
    }
  }
}

namespace {

// A lockstep loop without images: the controller sees the true target at each frame's capture
// with the heads' true PTZ; returns the RMS distance of the target's pixel from the image
// centre (both cameras) after 3 s.
double centringRmsPx(const ptz::sim::Trajectory& path, const std::string& mode, double delay_s,
                     double model_scale,
                     const std::string& kf_model = pc::ControllerParams().kf_model) {
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ptz::PtzPlant::Params plant = ptz::defaultPlantParams();
  for (auto& a : plant.axis) a.dead_time_s = delay_s;
  pc::ControllerParams cp;
  cp.mode = mode;
  cp.kf_model = kf_model;
  cp.limits = plant;
  for (int a = 0; a < 2; ++a) {
    cp.limits.axis[a].gain *= model_scale;
    cp.limits.axis[a].time_constant_s *= model_scale;
  }
  pc::Controller controller(rig, cp);
  std::mt19937 rng(5);
  std::normal_distribution<double> unit(0.0, 1.0);
  // Stereo noise at 3 m: ~1 mm across, ~1 cm in depth (0.3 px centroids, f 900 px, b 0.3 m).
  const Eigen::Vector3d sigma_m(0.001, 0.001, 0.01);
  ptz::PtzPlant heads(plant, {0, 0, 1}, {0, 0, 1});
  double sum_sq = 0;
  int n = 0;
  for (int k = 0; k < 30 * 30; ++k) {
    const double t = k / 30.0;
    heads.advanceTo(t);
    const Eigen::Vector3d p = path.position(t);
    const ptz::PtzPose left = heads.pose(ptz::Side::kLeft), right = heads.pose(ptz::Side::kRight);
    if (t >= 3.0) {
      for (auto [side, pose] : {std::pair{ptz::Side::kLeft, left}, {ptz::Side::kRight, right}}) {
        const Eigen::Vector2d px = rig.view(side, pose).project(p);
        sum_sq += (px - pc::imageCentre(rig.camera(side))).squaredNorm();
        ++n;
      }
    }
    pc::Observation seen{p + sigma_m.cwiseProduct(Eigen::Vector3d(unit(rng), unit(rng), unit(rng))),
                         0.1, sigma_m.cwiseAbs2().asDiagonal()};
    const auto sp = controller.update(t, seen, left, right);
    int clamped = 0, rejected = 0;
    heads.command(t, sp[0], sp[1], &clamped, &rejected);
  }
  return std::sqrt(sum_sq / n);
}

ptz::sim::Trajectory demoFigureEight() {
  ptz::sim::Trajectory path;
  path.type = ptz::sim::Trajectory::Type::kFigureEight;
  path.centre_m = {0.0, 0.1, 3.0};
  path.amplitude_m = {1.0, 0.2, 0.8};
  path.period_s = 30.0;
  return path;
}

double figureEightCentringRmsPx(const std::string& mode, double delay_s, double model_scale,
                                const std::string& kf_model = pc::ControllerParams().kf_model) {
  return centringRmsPx(demoFigureEight(), mode, delay_s, model_scale, kf_model);
}

}  // namespace

TEST(SmithMode, TracksAFigureEightWithOneSecondOfDelay) {
  const double smith_px = figureEightCentringRmsPx("smith", 1.0, 1.0);
  const double track_px = figureEightCentringRmsPx("track", 1.0, 1.0);
  const double smith_fast_px = figureEightCentringRmsPx("smith", 0.0, 1.0);
  std::printf("figure-eight, tau 1 s: smith %.2f px RMS, track %.2f px; smith at tau 0: %.2f px\n",
              smith_px, track_px, smith_fast_px);
  EXPECT_LE(smith_px, 20.0);
  EXPECT_LT(smith_px, track_px / 2);
  EXPECT_LE(smith_fast_px, 5.0);
  for (double scale : {0.7, 1.3}) {
    const double px = figureEightCentringRmsPx("smith", 0.6, scale);
    std::printf("figure-eight, tau 0.6 s, model K and T x%.1f: %.2f px RMS\n", scale, px);
    EXPECT_LE(px, 20.0);
  }
  // The turn model is no worse than constant velocity on the slow figure-eight.
  const double cv_px = figureEightCentringRmsPx("smith", 1.0, 1.0, "cv");
  const double ct_px = figureEightCentringRmsPx("smith", 1.0, 1.0, "ct");
  std::printf("figure-eight, tau 1 s: smith cv %.2f px RMS, ct %.2f px\n", cv_px, ct_px);
  EXPECT_LE(ct_px, cv_px * 1.1);
}

TEST(SmithMode, TheTurnModelTracksAFastCircleWithOneSecondOfDelay) {
  ptz::sim::Trajectory path;  // test/scenarios/fast_circle.yaml
  path.type = ptz::sim::Trajectory::Type::kCircle;
  path.centre_m = {0.0, 0.1, 2.0};
  path.amplitude_m = {0.6, 0.0, 0.6};
  path.period_s = 2.5133;
  const double ct_px = centringRmsPx(path, "smith", 1.0, 1.0, "ct");
  const double cv_px = centringRmsPx(path, "smith", 1.0, 1.0, "cv");
  std::printf("fast circle, tau 1 s: smith ct %.2f px RMS, cv %.2f px\n", ct_px, cv_px);
  EXPECT_LE(ct_px, 15.0);
  EXPECT_LT(ct_px, cv_px / 3);
}

namespace {
// Whether the track loop's response to a step settles: the last quarter's deviation from its
// final value is smaller than the second quarter's.
bool trackDecays(const pc::TrackLoopParams& loop, double g) {
  const auto y = pc::trackStepResponse(loop, g, 120.0, 1e-3);
  if (y.size() < 120001) return false;  // blew up
  const double final_value = 1.0 / (1.0 - g);
  auto envelope = [&](size_t from, size_t to) {
    double m = 0;
    for (size_t i = from; i < to; ++i) m = std::max(m, std::abs(y[i] - final_value));
    return m;
  };
  const size_t n = y.size();
  return envelope(3 * n / 4, n) < envelope(n / 2, 3 * n / 4) || envelope(3 * n / 4, n) < 1e-9;
}
}  // namespace

TEST(TrackAnalysis, MarginsForCalibrationErrorAgreeWithTheTimeResponse) {
  // ptz-control's default track mode (lead_s, rate_filter_s) at the paper's tau_max and at 1 s;
  // the analysis's defaults are the controller's.
  const pc::ControllerParams defaults;
  EXPECT_EQ(pc::TrackLoopParams().lead_s, defaults.lead_s);
  EXPECT_EQ(pc::TrackLoopParams().rate_filter_s, defaults.rate_filter_s);
  for (double tau : {0.384, 1.0}) {
    const pc::TrackLoopParams loop{0.24, defaults.lead_s, defaults.rate_filter_s, tau};
    const pc::TrackMargins m = pc::trackLoopMargins(loop);
    std::printf(
        "track, tau %.3f s: peak |PF| %.3f -> |g| < %.3f for any delay; here g in "
        "(-%.3f, %.3f)\n",
        tau, m.peak_gain, m.g_max_any_delay, m.g_max_negative, m.g_max_positive);
    // |F| rises to 1 + lead / Tv at high frequency and |P| falls: a peak just above 1.
    EXPECT_GT(m.peak_gain, 1.0);
    EXPECT_LT(m.g_max_any_delay, std::min(m.g_max_positive, m.g_max_negative) + 1e-9);
    EXPECT_LE(m.g_max_positive, 1.0);
    for (double g : {m.g_max_positive, -m.g_max_negative}) {
      EXPECT_TRUE(trackDecays(loop, 0.95 * g)) << "tau " << tau << ", g " << 0.95 * g;
      if (std::abs(g) < 1.0) {
        EXPECT_FALSE(trackDecays(loop, 1.05 * g)) << "tau " << tau << ", g " << 1.05 * g;
      }
    }
  }
}
