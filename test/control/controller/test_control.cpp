// The controller against the rig model: aiming, the zoom law, both modes, lost targets, limits.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "control/controller/controller.hpp"
#include "control/controller/pointing.hpp"

using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace control = ptz::control;

TEST(Pointing, AimPutsThePointAtTheImageCentreOfEitherCamera) {
  const StereoRig rig = StereoRig::makeDefault();  // optical centres 4 cm in front of the pivots
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(-3, 3), y(-1, 1), z(0.8, 6), zoom(1, 8);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p(x(rng), y(rng), z(rng));
    for (Side side : {Side::kLeft, Side::kRight}) {
      const double zm = zoom(rng);
      double pan = 0, tilt = 0;
      ASSERT_TRUE(
          control::aimAt(rig, side, p, zm, control::imageCentre(rig.camera(side)), &pan, &tilt));
      const Eigen::Vector2d px = rig.view(side, {pan, tilt, zm}).project(p);
      EXPECT_NEAR(px.x(), 319.5, 1e-3);
      EXPECT_NEAR(px.y(), 239.5, 1e-3);
    }
  }
}

TEST(Pointing, ZoomForFocalLengthInvertsTheZoomTable) {
  const StereoRig rig = StereoRig::makeDefault();
  for (double z : {1.0, 1.7, 2.0, 3.3, 6.5, 10.0}) {
    EXPECT_NEAR(control::zoomForFocalLength(rig.left, rig.left.intrinsicsAt(z).fx), z, 1e-9);
  }
  EXPECT_DOUBLE_EQ(control::zoomForFocalLength(rig.left, 10.0), 1.0);  // below the table
  EXPECT_DOUBLE_EQ(control::zoomForFocalLength(rig.left, 1e6), 10.0);  // above it
}

namespace {

struct Aim {
  double pan, tilt;
};
Aim aim(const StereoRig& rig, Side side, const Eigen::Vector3d& p, double zoom) {
  Aim a{};
  control::aimAt(rig, side, p, zoom, control::imageCentre(rig.camera(side)), &a.pan, &a.tilt);
  return a;
}

control::ControllerParams fast() {
  control::ControllerParams p;
  p.max_setpoint_rate = 1000;  // no slew limit unless a test wants one
  return p;
}

}  // namespace

TEST(Controller, PaperModeIsAProportionalElementOnTheAngularError) {
  const StereoRig rig = StereoRig::makeDefault();
  auto params = fast();
  params.mode = "paper";
  params.zoom_mode = "hold";
  control::Controller c(rig, params);
  const Eigen::Vector3d p(0.6, -0.2, 3.0);
  const PtzPose lc{0.05, 0.02, 1}, rc{0.04, 0.01, 1};
  const auto sp = c.update(0.0, control::Observation{p, 0.1}, lc, rc);
  const Aim al = aim(rig, Side::kLeft, p, 1), ar = aim(rig, Side::kRight, p, 1);
  EXPECT_NEAR(sp[0].pan_rad, 1.7 * (al.pan - lc.pan_rad), 1e-9);
  EXPECT_NEAR(sp[0].tilt_rad, 1.7 * (al.tilt - lc.tilt_rad), 1e-9);
  EXPECT_NEAR(sp[1].pan_rad, 1.7 * (ar.pan - rc.pan_rad), 1e-9);
  EXPECT_DOUBLE_EQ(sp[0].zoom, 1.0);  // held
}

TEST(Controller, TrackModeHasNoSteadyStateErrorForAStillTarget) {
  const StereoRig rig = StereoRig::makeDefault();
  control::Controller c(rig, fast());
  const Eigen::Vector3d p(-0.8, 0.3, 2.5);
  std::array<PtzPose, 2> sp{};
  for (int k = 0; k < 30; ++k) sp = c.update(k / 30.0, control::Observation{p, 0.1}, sp[0], sp[1]);
  for (Side side : {Side::kLeft, Side::kRight}) {
    const int i = static_cast<int>(side);
    const Aim a = aim(rig, side, p, sp[i].zoom);
    // 1e-6 rad: a thousandth of a pixel at 10x zoom.
    EXPECT_NEAR(sp[i].pan_rad, a.pan, 1e-6);
    EXPECT_NEAR(sp[i].tilt_rad, a.tilt, 1e-6);
    // The zoom gives the 0.1 m ball a radius of 30 px.
    Eigen::Matrix3d R;
    Eigen::Vector3d centre;
    rig.cameraPose(side, sp[i].pan_rad, sp[i].tilt_rad, &R, &centre);
    EXPECT_NEAR(rig.camera(side).intrinsicsAt(sp[i].zoom).fx * 0.1 / (p - centre).norm(), 30.0,
                0.3);
  }
}

TEST(Controller, TrackModeLeadsAMovingTargetByItsRateTimesTheLead) {
  const StereoRig rig = StereoRig::makeDefault();
  auto params = fast();
  params.zoom_mode = "hold";
  control::Controller c(rig, params);
  // A target sweeping across at 3 m: its bearing changes at a nearly constant rate.
  std::array<PtzPose, 2> sp{};
  Eigen::Vector3d p;
  for (int k = 0; k < 120; ++k) {
    p = Eigen::Vector3d(-0.5 + 0.3 * k / 30.0, 0.0, 3.0);
    sp = c.update(k / 30.0, control::Observation{p, 0.1}, sp[0], sp[1]);
  }
  const double dt = 1e-3;
  const Aim now = aim(rig, Side::kLeft, p, 1),
            before = aim(rig, Side::kLeft, p - Eigen::Vector3d(0.3 * dt, 0, 0), 1);
  const double rate = (now.pan - before.pan) / dt;
  EXPECT_NEAR(sp[0].pan_rad, now.pan + rate * params.lead_s, 0.02 * rate * params.lead_s);
}

TEST(Controller, LostTargetHoldsThenReturnsHomeAndResumesWithoutAJump) {
  const StereoRig rig = StereoRig::makeDefault();
  control::ControllerParams params;  // default slew limit 3 rad/s
  params.lost_mode = "home";
  control::Controller c(rig, params);
  const Eigen::Vector3d p(1.5, -0.4, 3.0);
  std::array<PtzPose, 2> sp{};
  double t = 0;
  for (; t < 2.0; t += 1 / 30.0) sp = c.update(t, control::Observation{p, 0.1}, sp[0], sp[1]);
  const auto tracked = sp;
  // Lost: held for lost_hold_s ...
  for (; t < 2.0 + params.lost_hold_s - 0.05; t += 1 / 30.0) {
    sp = c.update(t, std::nullopt, sp[0], sp[1]);
    EXPECT_DOUBLE_EQ(sp[0].pan_rad, tracked[0].pan_rad);
  }
  // ... then back towards home at home_rate.
  double previous = sp[0].pan_rad;
  for (; t < 4.0; t += 1 / 30.0) {
    sp = c.update(t, std::nullopt, sp[0], sp[1]);
    EXPECT_LE(previous - sp[0].pan_rad, params.home_rate / 30.0 + 1e-9);
    EXPECT_LE(sp[0].pan_rad, previous + 1e-12);
    previous = sp[0].pan_rad;
  }
  EXPECT_LT(sp[0].pan_rad, tracked[0].pan_rad - 0.3);
  // Found again: the setpoint slews, it does not jump.
  const auto before = sp;
  sp = c.update(t, control::Observation{p, 0.1}, sp[0], sp[1]);
  EXPECT_LE(std::abs(sp[0].pan_rad - before[0].pan_rad), params.max_setpoint_rate / 30.0 + 1e-9);
  EXPECT_GT(sp[0].pan_rad, before[0].pan_rad);
}

TEST(Controller, ImplausibleTargetsAreIgnoredAndLimitsHold) {
  const StereoRig rig = StereoRig::makeDefault();
  auto params = fast();
  control::Controller c(rig, params);
  const double nan = std::nan("");
  const PtzPose home{0, 0, 1};
  EXPECT_FALSE(c.plausible({Eigen::Vector3d(nan, 0, 3), 0.1}, home, home));
  EXPECT_FALSE(c.plausible({Eigen::Vector3d(0, 0, 1e6), 0.1}, home, home));
  EXPECT_FALSE(c.plausible({Eigen::Vector3d(0, 0, -2), 0.1}, home, home));
  EXPECT_FALSE(
      c.plausible({Eigen::Vector3d(0, 0, 3), std::numeric_limits<double>::infinity()}, home, home));
  EXPECT_TRUE(c.plausible({Eigen::Vector3d(0, 0, 3), 0.1}, home, home));
  // Behind the head frame but in front of both cameras turned round: plausible.
  const PtzPose behind{M_PI * 160 / 180, 0, 1};
  EXPECT_TRUE(c.plausible({Eigen::Vector3d(1, 0, -3), 0.1}, behind, behind));
  EXPECT_FALSE(c.plausible({Eigen::Vector3d(0, 0, 3), 0.1}, behind, behind));
  // In front of one camera only (the other turned away): implausible.
  EXPECT_FALSE(c.plausible({Eigen::Vector3d(0, 0, 3), 0.1}, home, behind));
  // A target far up: tilt stops at its +90 deg limit... and far right beyond pan's 170 deg.
  std::array<PtzPose, 2> sp{};
  for (int k = 0; k < 10; ++k) {
    sp = c.update(k / 30.0, control::Observation{Eigen::Vector3d(0.01, -30, 0.02), 0.1}, sp[0],
                  sp[1]);
  }
  EXPECT_LE(sp[0].tilt_rad, params.limits.axis[1].max_position);
  EXPECT_GE(sp[0].zoom, 1.0);
  EXPECT_LE(sp[0].zoom, params.max_zoom);
}

namespace {

// A still target followed as track `id` for a second, then seen 0.8 m away as track `next_id`.
struct Jump {
  std::array<PtzPose, 2> setpoint{};
  int64_t outliers = 0;
};
Jump jumpTo(const std::string& mode, int64_t next_id) {
  const StereoRig rig = StereoRig::makeDefault();
  auto params = fast();
  params.mode = mode;
  params.zoom_mode = "hold";
  control::Controller c(rig, params);
  const Eigen::Vector3d here(0.0, 0.0, 3.0), there(0.8, 0.0, 3.0);
  std::array<PtzPose, 2> sp{PtzPose{0, 0, 1}, PtzPose{0, 0, 1}};
  for (int k = 0; k < 30; ++k) {
    control::Observation o{here, 0.1};
    o.track_id = 7;
    sp = c.update(k / 30.0, o, sp[0], sp[1]);
  }
  control::Observation o{there, 0.1};
  o.track_id = next_id;
  Jump j;
  j.setpoint = c.update(1.0, o, sp[0], sp[1]);
  j.outliers = c.outliersRejected();
  return j;
}

}  // namespace

TEST(Controller, ANewTargetIdStartsTheFiltersAfresh) {
  // Smith mode: the jump to another track is no outlier of the old track's Kalman filter; the
  // same track jumping there is (its gate is a few cm wide).
  EXPECT_EQ(jumpTo("smith", 8).outliers, 0);
  EXPECT_EQ(jumpTo("smith", 7).outliers, 1);
  // Track mode (no track velocity: the filtered rate): after the switch the rate starts from
  // zero, the setpoint is the new target's aim exactly; the same id's jump is a huge "rate".
  const StereoRig rig = StereoRig::makeDefault();
  const Aim there = aim(rig, Side::kLeft, Eigen::Vector3d(0.8, 0.0, 3.0), 1);
  EXPECT_NEAR(jumpTo("track", 8).setpoint[0].pan_rad, there.pan, 1e-9);
  EXPECT_GT(jumpTo("track", 7).setpoint[0].pan_rad, there.pan + 0.1);
}

TEST(Controller, ANewTargetSeenFirstCoastingIsAimedAtNotTheOldOnesPrediction) {
  // The old target moves left at 0.6 m/s; the new one (a hidden track's prediction, to the
  // right) must start the smith filter: aimed at, not the old target's extrapolation.
  const StereoRig rig = StereoRig::makeDefault();
  auto params = fast();
  params.mode = "smith";
  params.zoom_mode = "hold";
  control::Controller c(rig, params);
  std::array<PtzPose, 2> sp{PtzPose{0, 0, 1}, PtzPose{0, 0, 1}};
  for (int k = 0; k < 30; ++k) {
    control::Observation o{Eigen::Vector3d(-0.02 * k, 0.0, 3.0), 0.1};
    o.track_id = 7;
    sp = c.update(k / 30.0, o, sp[0], sp[1]);
  }
  const double old_pan = sp[0].pan_rad;
  for (int k = 30; k < 45; ++k) {
    control::Observation o{Eigen::Vector3d(0.8, 0.0, 3.0), 0.1};
    o.track_id = 8;
    o.measured = false;
    sp = c.update(k / 30.0, o, sp[0], sp[1]);
  }
  EXPECT_GT(sp[0].pan_rad, old_pan + 0.05);
  EXPECT_GT(sp[0].pan_rad, 0.0);
}

TEST(Controller, ACovarianceThatIsNoCovarianceIsNotUsed) {
  // Indefinite, asymmetric, huge: each would turn the filter's state to NaN and freeze the heads.
  const StereoRig rig = StereoRig::makeDefault();
  for (const char* model : {"ct", "cv"}) {
    auto params = fast();
    params.mode = "smith";
    params.zoom_mode = "hold";
    params.kf_model = model;
    control::Controller c(rig, params);
    std::array<PtzPose, 2> sp{PtzPose{0, 0, 1}, PtzPose{0, 0, 1}};
    Eigen::Vector3d target;
    const Eigen::Matrix3d bad[3] = {
        Eigen::Vector3d(1e-4, -0.9e-4, 1e-4).asDiagonal(),
        (Eigen::Matrix3d() << 1e-4, 5, 0, 0, 1e-4, 0, 0, 0, 1e-4).finished(),
        Eigen::Matrix3d::Identity() * 1e308};
    for (int k = 0; k < 90; ++k) {
      target = Eigen::Vector3d(0.3 + 0.005 * k, 0.1 * std::sin(k / 5.0), 3.0);
      control::Observation o{target, 0.1, bad[k % 3]};
      sp = c.update(k / 30.0, o, sp[0], sp[1]);
      ASSERT_TRUE(std::isfinite(sp[0].pan_rad) && std::isfinite(sp[1].tilt_rad)) << model << k;
    }
    EXPECT_NEAR(sp[0].pan_rad, aim(rig, Side::kLeft, target, 1).pan, 0.02) << model;
  }
}
