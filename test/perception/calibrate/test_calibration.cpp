// Calibration against known answers: OpenCV's real stereo sample, the Bouguet toolbox's answers
// for OpenCV's regression points, and rigs drawn at random and rendered by the simulator.
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include <fstream>
#include <random>

#include "perception/calibrate/calibration.hpp"
#include "perception/calibrate/calibration_files.hpp"
#include "support/board_views.hpp"
#include "support/data_dir.hpp"

namespace {

using ptz::perception::BoardSpec;
using ptz::perception::StereoCalibration;
using ptz::perception::ViewPair;

double relativeError(double value, double truth) {
  return std::abs(value - truth) / std::abs(truth);
}

const BoardSpec kSampleBoard{9, 6, 0.025};

std::string sampleDir() {
  return ptz::test::dataDir() + "/opencv_stereo_calib";
}

// The board in OpenCV's 13 sample pairs.
ptz::perception::DetectedViews detectSample() {
  return ptz::perception::detectPairs(
      ptz::perception::pairsFromFolder(sampleDir(), "left", "right"), kSampleBoard);
}

TEST(Calibration, OpenCvStereoSampleMeetsTheReferenceNumbers) {
  PTZ_REQUIRE_DATA(sampleDir());
  const BoardSpec board = kSampleBoard;
  const auto detected = detectSample();
  ASSERT_EQ(detected.views.size(), 13u);
  const StereoCalibration c =
      ptz::perception::calibrateStereo(detected.views, board, detected.image_size, {});
  EXPECT_EQ(c.views.size(), 13u);
  EXPECT_LE(c.stereo_rms_px, 0.45);
  EXPECT_LE(c.rectified_epipolar_px, 0.15);
  EXPECT_LT(relativeError(cv::norm(c.T) / board.square_m, 3.345), 0.005) << cv::norm(c.T);
  EXPECT_TRUE(c.outliers.empty());
}

TEST(Calibration, DropsOutlierViewsWhenAskedAndSaysWhy) {
  PTZ_REQUIRE_DATA(sampleDir());
  const BoardSpec board = kSampleBoard;
  const auto detected = detectSample();
  ptz::perception::StereoOptions options;
  options.max_view_error_px = 0.5;  // below the worst views of this set
  const StereoCalibration kept =
      ptz::perception::calibrateStereo(detected.views, board, detected.image_size, options);
  std::vector<std::string> worse;  // the views above the threshold, by the fit's own errors
  for (const auto& v : kept.views) {
    if (std::max(v.left_rms_px, v.right_rms_px) > 0.5) worse.push_back(v.left_name);
  }
  ASSERT_FALSE(worse.empty());
  ASSERT_EQ(kept.outliers.size(), worse.size());
  EXPECT_TRUE(kept.dropped.empty());
  EXPECT_EQ(kept.views.size(), 13u);

  options.drop_outliers = true;
  const StereoCalibration c =
      ptz::perception::calibrateStereo(detected.views, board, detected.image_size, options);
  ASSERT_EQ(c.dropped.size(), worse.size());
  for (size_t i = 0; i < worse.size(); ++i) {
    EXPECT_NE(c.dropped[i].name.find(worse[i]), std::string::npos) << c.dropped[i].name;
    EXPECT_NE(c.dropped[i].reason.find("max_view_error_px"), std::string::npos);
  }
  EXPECT_EQ(c.views.size(), 13u - worse.size());
  for (const auto& v : c.views) {
    EXPECT_EQ(std::count(worse.begin(), worse.end(), v.left_name), 0) << v.left_name;
  }

  options.max_view_error_px = 0.01;  // every view an outlier: nothing left to calibrate with
  try {
    ptz::perception::calibrateStereo(detected.views, board, detected.image_size, options);
    ADD_FAILURE() << "dropped every view and still calibrated";
  } catch (const ptz::perception::CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("would leave 0, fewer than min_views"), std::string::npos)
        << e.what();
  }
}

// OpenCV's calib1.dat: object and image points with the Caltech toolbox's answers.
TEST(Calibration, MonoMatchesTheBouguetToolboxAnswers) {
  const std::string path = ptz::test::dataDir() + "/opencv_calib_known_answers/calib1.dat";
  PTZ_REQUIRE_DATA(path);
  std::ifstream in(path);
  int width = 0, height = 0, cols = 0, rows = 0, views = 0, flags = 0;
  in >> width >> height >> cols >> rows >> views >> flags;
  const size_t n = static_cast<size_t>(cols * rows);
  std::vector<std::vector<cv::Point3f>> object(static_cast<size_t>(views));
  std::vector<std::vector<cv::Point2f>> image(static_cast<size_t>(views));
  for (auto& v : object) {
    v.resize(n);
    for (auto& p : v) in >> p.x >> p.y >> p.z;
  }
  for (auto& v : image) {
    v.resize(n);
    for (auto& p : v) in >> p.x >> p.y;
  }
  double fx, fy, cx, cy;
  std::array<double, 4> kc{};
  in >> fx >> fy >> cx >> cy >> kc[0] >> kc[1] >> kc[2] >> kc[3];
  ASSERT_TRUE(in) << path << ": could not read the points and answers";
  const auto m = ptz::perception::calibrateMono(object, image, {width, height}, flags, path);
  const ptz::Intrinsics k = m.intrinsics();
  EXPECT_LT(relativeError(k.fx, fx), 0.001) << k.fx << " vs " << fx;
  EXPECT_LT(relativeError(k.fy, fy), 0.001) << k.fy << " vs " << fy;
  EXPECT_LT(relativeError(k.cx, cx), 0.001) << k.cx << " vs " << cx;
  EXPECT_LT(relativeError(k.cy, cy), 0.001) << k.cy << " vs " << cy;
  double worst_kc = 0;
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_LT(relativeError(k.distortion[i], kc[i]), 0.01) << "kc[" << i << "] " << k.distortion[i];
    worst_kc = std::max(worst_kc, relativeError(k.distortion[i], kc[i]));
  }
  std::printf("calib1.dat: fx %.5f %%, fy %.5f %%, cx %.5f %%, cy %.5f %%, worst kc %.4f %%\n",
              100 * relativeError(k.fx, fx), 100 * relativeError(k.fy, fy),
              100 * relativeError(k.cx, cx), 100 * relativeError(k.cy, cy), 100 * worst_kc);
}

// 20 views of a rig the test draws at random, rendered by the simulator.
TEST(Calibration, RecoversARandomSimulatedRig) {
  std::mt19937 rng(20261122);
  const ptz::StereoRig truth = ptz::test::randomRig(rng);
  ptz::test::BoardScene sim;
  const BoardSpec board = sim.board;
  const std::vector<ViewPair> pairs = ptz::test::stereoViews(truth, &sim, rng, 20);
  ASSERT_EQ(pairs.size(), 20u);
  const StereoCalibration c = ptz::perception::calibrateStereo(pairs, board, {640, 480}, {});
  const ptz::StereoRig rig = c.toRig();
  double worst_c_px = 0;
  for (ptz::Side side : {ptz::Side::kLeft, ptz::Side::kRight}) {
    const ptz::Intrinsics t = truth.camera(side).intrinsicsAt(1),
                          e = rig.camera(side).intrinsicsAt(1);
    EXPECT_LT(relativeError(e.fx, t.fx), 0.003)
        << ptz::sideName(side) << " " << e.fx << " vs " << t.fx;
    EXPECT_LT(relativeError(e.fy, t.fy), 0.003)
        << ptz::sideName(side) << " " << e.fy << " vs " << t.fy;
    EXPECT_LT(std::hypot(e.cx - t.cx, e.cy - t.cy), 2.0) << ptz::sideName(side);
    worst_c_px = std::max(worst_c_px, std::hypot(e.cx - t.cx, e.cy - t.cy));
  }
  EXPECT_LT(relativeError(rig.baselineM(), truth.baselineM()), 0.005)
      << rig.baselineM() << " vs " << truth.baselineM();
  const double angle_deg =
      Eigen::AngleAxisd(rig.home.R * truth.home.R.transpose()).angle() * 180 / M_PI;
  EXPECT_LT(angle_deg, 0.1);
  EXPECT_LT(c.rectified_epipolar_px, 0.1);
  std::printf(
      "simulated rig: fx %.4f %%, principal point %.2f px, baseline %.4f %%, rotation %.4f deg, "
      "stereo RMS %.3f px\n",
      100 * relativeError(rig.left.intrinsicsAt(1).fx, truth.left.intrinsicsAt(1).fx), worst_c_px,
      100 * relativeError(rig.baselineM(), truth.baselineM()), angle_deg, c.stereo_rms_px);
}

}  // namespace
