// ptz-head-calibrate's measurement on rendered images with known answers: a turn and a zoom step
// from the images alone, then the whole procedure against a head whose map (pan, tilt and a
// non-linear zoom) differs from the model file it starts from, its result written and read back.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

#include "ptz_driver/head_calibrate/head_calibration.hpp"
#include "ptz_driver/head_calibrate/unit_map_files.hpp"
#include "ptz_driver/head_calibrate/view_fit.hpp"
#include "ptz_driver/heads/onvif/head/onvif_model.hpp"
#include "ptz_driver/heads/visca/visca_model.hpp"
#include "sim/render/renderer.hpp"
#include "support/focal_length_error.hpp"

namespace {

using ptz::PtzPose;
using ptz::Side;
constexpr double kDeg = M_PI / 180;

// The simulator's default rig and backdrop, rendered grey with the simulator's noise.
class Camera {
 public:
  Camera() : rig_(ptz::StereoRig::makeDefault()), renderer_(scene_) {}
  const ptz::StereoRig& rig() const { return rig_; }
  cv::Mat grey(Side side, const PtzPose& pose, bool noise = true) {
    cv::Mat& clean =
        cache_[std::make_tuple(side == Side::kLeft, pose.pan_rad, pose.tilt_rad, pose.zoom)];
    if (clean.empty()) {
      cv::Mat bgr;
      renderer_.render(rig_.view(side, pose), 0.0, &bgr);
      cv::cvtColor(bgr, clean, cv::COLOR_BGR2GRAY);
    }
    if (!noise) return clean;
    cv::Mat noisy(clean.size(), CV_16SC1);
    cv::randn(noisy, 0, 2.0);
    cv::Mat out;
    cv::add(clean, noisy, out, cv::noArray(), CV_8U);
    return out;
  }

 private:
  ptz::StereoRig rig_;
  ptz::sim::Scene scene_;
  ptz::sim::Renderer renderer_;
  std::map<std::tuple<bool, double, double, double>, cv::Mat> cache_;
};

TEST(ViewFit, ATurnIsMeasuredFromTheImagesAndTheHomeStereoPair) {
  Camera c;
  const double zoom = c.rig().left.minZoom();
  const cv::Mat left = c.grey(Side::kLeft, {0, 0, zoom}),
                right = c.grey(Side::kRight, {0, 0, zoom});
  const ptz::driver::ScenePoints scene =
      ptz::driver::triangulateAtHome(c.rig(), Side::kLeft, zoom, left, right, 500);
  ASSERT_GT(scene.pixels.size(), 100u);
  const cv::Mat turned = c.grey(Side::kLeft, {3 * kDeg, -2 * kDeg, zoom});
  const ptz::driver::Tracks t = ptz::driver::track(left, turned, scene.pixels);
  std::vector<Eigen::Vector3d> points;
  for (int i : t.index) points.push_back(scene.points_head_m[i]);
  const ptz::driver::Fit fit =
      ptz::driver::fitPanTilt(c.rig(), Side::kLeft, zoom, points, t.to, 0, 0);
  ASSERT_TRUE(fit.ok) << fit.why;
  EXPECT_NEAR(fit.value[0], 3 * kDeg, 0.003 * kDeg);  // 0.1 % of the turn
  EXPECT_NEAR(fit.value[1], -2 * kDeg, 0.003 * kDeg);
  // Corners from every part of the image (fainter ones too): 0.100 px measured.
  EXPECT_LT(fit.rms_px, 0.12);
}

TEST(ViewFit, AZoomStepIsMeasuredFromTheScaleOfTheScene) {
  Camera c;
  const double from = 1.0, to = 1.25;
  const cv::Mat wide = c.grey(Side::kRight, {0, 0, from}),
                narrow = c.grey(Side::kRight, {0, 0, to});
  const auto corners = ptz::driver::findCorners(wide, 500);
  const ptz::driver::Tracks t = ptz::driver::track(
      wide, narrow, corners,
      ptz::driver::zoomedPixels(c.rig(), Side::kRight, from, 1.15, corners));  // a guess off
  const ptz::driver::Fit fit =
      ptz::driver::fitZoom(c.rig(), Side::kRight, from, t.from, t.to, 1.15);
  ASSERT_TRUE(fit.ok) << fit.why;
  EXPECT_NEAR(fit.value[0], to, 0.001 * to);
}

TEST(ViewFit, CornersNotFoundAgainAreAFailureWithItsReason) {
  Camera c;
  const cv::Mat wide = c.grey(Side::kLeft, {0, 0, 1.0});
  const cv::Mat blank(wide.size(), CV_8UC1, cv::Scalar(128));  // the lens capped
  const auto corners = ptz::driver::findCorners(wide, 500);
  const ptz::driver::Tracks t = ptz::driver::track(wide, blank, corners);
  EXPECT_LT(t.to.size(), 20u);
  const ptz::driver::Fit zoom = ptz::driver::fitZoom(c.rig(), Side::kLeft, 1.0, t.from, t.to, 1.2);
  EXPECT_FALSE(zoom.ok);
  EXPECT_NE(zoom.why.find("corners were found again"), std::string::npos) << zoom.why;
  const ptz::driver::Fit turn = ptz::driver::fitPanTilt(c.rig(), Side::kLeft, 1.0, {}, {}, 0, 0);
  EXPECT_FALSE(turn.ok);
  EXPECT_TRUE(std::isinf(ptz::driver::imageMotionPx(t)));
}

// A head of a known map in its units, always where it was sent (the procedure's waiting is the
// process test's), seen through the rendered cameras at 30 frames a second.
template <class ToPose>
ptz::driver::UnitMap calibrate(Camera& c, const ptz::driver::UnitMapGuess& guess,
                               const ToPose& to_pose) {
  ptz::driver::HeadCalibration calibration(c.rig(), guess, {});
  double now_s = 100;
  for (int frame = 0; frame < 20000; ++frame, now_s += 1.0 / 30) {
    const ptz::driver::UnitPose u = calibration.target();
    const PtzPose pose = to_pose(u);
    const auto state =
        calibration.onFrame(c.grey(Side::kLeft, pose), c.grey(Side::kRight, pose), now_s, {u, u});
    for (const auto& line : calibration.takeLog()) std::printf("  %s\n", line.c_str());
    if (state == ptz::driver::HeadCalibration::State::kFailed) {
      ADD_FAILURE() << calibration.error();
      break;
    }
    if (state == ptz::driver::HeadCalibration::State::kDone) break;
  }
  EXPECT_EQ(calibration.state(), ptz::driver::HeadCalibration::State::kDone);
  return calibration.result();
}

TEST(HeadCalibration, AnOnvifCamerasMapIsMeasuredFromAModelFileThatIsWrong) {
  Camera c;
  // The camera: pan 1 unit = 150 deg, tilt -1..1 over -40..80 deg, the cheap camera's zoom.
  ptz::driver::OnvifModel truth =
      ptz::driver::OnvifModel::load(PTZ_SOURCE_DIR "/config/onvif/cheap_ptz.yaml");
  truth.pan_min_rad = -150 * kDeg;
  truth.pan_max_rad = 150 * kDeg;
  truth.tilt_min_rad = -40 * kDeg;
  truth.tilt_max_rad = 80 * kDeg;
  // The file at hand: the generic camera (pan 170 deg, tilt -30..90, another zoom).
  const std::string generic = PTZ_SOURCE_DIR "/config/onvif/generic_ptz.yaml";
  ptz::driver::UnitMapGuess guess = ptz::driver::guessFromModelFile("onvif", generic);
  guess.home.tilt = truth.tiltNormalised(0);  // home as the user found it
  const auto map = calibrate(c, guess, [&](const ptz::driver::UnitPose& u) {
    return PtzPose{truth.panRad(u.pan), truth.tiltRad(u.tilt), truth.zoomRatio(u.zoom)};
  });
  const std::string out = ::testing::TempDir() + "measured_onvif.yaml";
  ASSERT_NO_THROW(ptz::driver::writeModelFile("onvif", generic, guess, map, out));
  const ptz::driver::OnvifModel measured = ptz::driver::OnvifModel::load(out);
  // Pan and tilt scales within 0.5 % (over the whole space, so the ends too), home at 0.
  EXPECT_NEAR(measured.pan_max_rad, truth.pan_max_rad, 0.005 * 150 * kDeg);
  EXPECT_NEAR(measured.pan_min_rad, truth.pan_min_rad, 0.005 * 150 * kDeg);
  EXPECT_NEAR(measured.tilt_max_rad - measured.tilt_min_rad, 120 * kDeg, 0.005 * 120 * kDeg);
  EXPECT_NEAR(measured.tiltRad(guess.home.tilt), 0, 1e-9);
  // The zoom: the focal length within 2 % over the range, at every 0.01.
  const double worst = ptz::test::worstFocalLengthError(
      c.rig(), 0, 1, 0.01, [&](double u) { return truth.zoomRatio(u); },
      [&](double u) { return measured.zoomRatio(u); });
  std::printf("pan %+.4f %%, tilt %+.4f %%, focal length within %.3f %% (%zu zoom positions)\n",
              100 * (measured.pan_max_rad / truth.pan_max_rad - 1),
              100 * ((measured.tilt_max_rad - measured.tilt_min_rad) / (120 * kDeg) - 1),
              100 * worst, map.zoom_units.size());
}

TEST(HeadCalibration, AViscaCamerasMapIsMeasuredFromAnotherModelsFile) {
  Camera c;
  const ptz::driver::ViscaModel truth =
      ptz::driver::ViscaModel::load(PTZ_SOURCE_DIR "/config/visca/sony_srg300.yaml");
  // Started from the EVI-D70's file: a quarter of the SRG-300's units per degree.
  const std::string other = PTZ_SOURCE_DIR "/config/visca/sony_evi_d70.yaml";
  ptz::driver::UnitMapGuess guess = ptz::driver::guessFromModelFile("visca_ip", other);
  guess.zoom_max_units = 14000;  // 9.1x: the rig's zoom table ends at 10x
  const auto map = calibrate(c, guess, [&](const ptz::driver::UnitPose& u) {
    return PtzPose{truth.panRad(static_cast<int>(u.pan)), truth.tiltRad(static_cast<int>(u.tilt)),
                   truth.zoomRatio(static_cast<int>(u.zoom))};
  });
  const std::string out = ::testing::TempDir() + "measured_visca.yaml";
  ASSERT_NO_THROW(ptz::driver::writeModelFile("visca_ip", other, guess, map, out));
  const ptz::driver::ViscaModel measured = ptz::driver::ViscaModel::load(out);
  EXPECT_NEAR(measured.pan_units_per_rad / truth.pan_units_per_rad, 1, 0.005);
  EXPECT_NEAR(measured.tilt_units_per_rad / truth.tilt_units_per_rad, 1, 0.005);
  const double worst = ptz::test::worstFocalLengthError(
      c.rig(), 0, 14000, 100, [&](double u) { return truth.zoomRatio(static_cast<int>(u)); },
      [&](double u) { return measured.zoomRatio(static_cast<int>(u)); });
  std::printf("pan %+.4f %%, tilt %+.4f %%, focal length within %.3f %% (%zu zoom positions)\n",
              100 * (measured.pan_units_per_rad / truth.pan_units_per_rad - 1),
              100 * (measured.tilt_units_per_rad / truth.tilt_units_per_rad - 1), 100 * worst,
              map.zoom_units.size());
}

}  // namespace
