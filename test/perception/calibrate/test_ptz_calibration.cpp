// The PTZ part of calibration against the simulator's true rig: the zoom table and the offset of
// the optical centre from the pan/tilt pivot, judged by what the rig model then predicts.
#include <gtest/gtest.h>

#include <random>

#include "perception/calibrate/ptz_calibration.hpp"
#include "perception/detection/stereo.hpp"
#include "support/board_views.hpp"

namespace {

using ptz::perception::BoardSpec;

using SimBoard = ptz::test::BoardScene;

TEST(ZoomTable, InterpolatesFocalLengthWithinOnePercentBetweenCalibratedZooms) {
  std::mt19937 rng(4);
  const ptz::StereoRig truth = ptz::StereoRig::makeDefault();  // f = 500 zoom, distortion ~1/zoom
  SimBoard sim;
  std::vector<ptz::perception::ZoomViews> zooms;
  for (double zoom : {1.0, 2.0, 3.0, 4.0}) {
    const ptz::CameraView view = truth.view(ptz::Side::kLeft, {0, 0, zoom});
    ptz::perception::ZoomViews z{zoom, {}};
    // The same apparent board size at every zoom: the board moves away as f grows.
    for (int i = 0; z.corners_px.size() < 12 && i < 40; ++i) {
      ASSERT_TRUE(ptz::test::placeBoard(rng, {view}, {0, 0, 1.1 * zoom},
                                        Eigen::Vector3d(0.3, 0.2, 0.25) * zoom, 0.8,
                                        &sim.chessboard()));
      std::vector<cv::Point2f> corners;
      if (sim.corners(view, &corners)) {
        z.corners_px.push_back(corners);
      }
    }
    zooms.push_back(z);
  }
  const auto table = ptz::perception::calibrateZoomTable(zooms, sim.board, {640, 480});
  ASSERT_EQ(table.size(), 4u);
  ptz::CameraSpec spec = truth.left;
  spec.zoom_table = table;
  double worst = 0;
  for (double zoom = 1.0; zoom <= 4.0; zoom += 0.25) {
    const ptz::Intrinsics t = truth.left.intrinsicsAt(zoom), e = spec.intrinsicsAt(zoom);
    const double error = std::max(std::abs(e.fx - t.fx) / t.fx, std::abs(e.fy - t.fy) / t.fy);
    EXPECT_LT(error, 0.01) << "zoom " << zoom << ": fx " << e.fx << " vs " << t.fx;
    worst = std::max(worst, error);
  }
  std::printf("zoom table 1-4x: worst interpolated f error %.3f %%\n", 100 * worst);
}

// Views of a static board at several pans and tilts of one camera of the true rig.
std::vector<ptz::perception::PivotView> pivotViews(const ptz::StereoRig& truth, ptz::Side side,
                                                   SimBoard* sim) {
  std::vector<ptz::perception::PivotView> views;
  int station = 0;
  for (double x_m : {-0.25, 0.25}) {
    sim->chessboard().centre_head_m = {x_m, 0.0, 1.4};
    sim->chessboard().rotation_head_board =
        Eigen::AngleAxisd(x_m, Eigen::Vector3d::UnitY()).toRotationMatrix();
    for (double pan_deg : {-15.0, -7.5, 0.0, 7.5, 15.0}) {
      for (double tilt_deg : {-10.0, 0.0, 10.0}) {
        const ptz::PtzPose pose{pan_deg * M_PI / 180, tilt_deg * M_PI / 180, 1};
        const ptz::CameraView view = truth.view(side, pose);
        if (!ptz::test::boardInside(sim->chessboard(), view, 20)) continue;
        ptz::perception::PivotView v{station, {}, pose.pan_rad, pose.tilt_rad};
        if (sim->corners(view, &v.corners_px)) {
          views.push_back(v);
        }
      }
    }
    ++station;
  }
  return views;
}

TEST(PanTiltKinematics, TriangulationAfterPanningStaysWithinHalfAPercentOfRange) {
  std::mt19937 rng(6);
  ptz::StereoRig truth = ptz::test::randomRig(rng);
  truth.left.optical_centre_from_pivot_m = {0.004, -0.012, 0.05};
  truth.right.optical_centre_from_pivot_m = {-0.003, -0.01, 0.035};
  SimBoard sim;
  // Home calibration, then the pivot offset of each camera with the calibrated intrinsics.
  const auto pairs = ptz::test::stereoViews(truth, &sim, rng, 20);
  ASSERT_EQ(pairs.size(), 20u);
  ptz::StereoRig rig = ptz::perception::calibrateStereo(pairs, sim.board, {640, 480}, {}).toRig();
  for (ptz::Side side : {ptz::Side::kLeft, ptz::Side::kRight}) {
    const auto views = pivotViews(truth, side, &sim);
    ASSERT_GE(views.size(), 12u) << ptz::sideName(side);
    const auto estimate = ptz::perception::estimateOpticalCentreFromPivot(
        views, sim.board, rig.camera(side).intrinsicsAt(1));
    (side == ptz::Side::kLeft ? rig.left : rig.right).optical_centre_from_pivot_m =
        estimate.optical_centre_from_pivot_m;
    const Eigen::Vector3d error =
        estimate.optical_centre_from_pivot_m - truth.camera(side).optical_centre_from_pivot_m;
    std::printf("%s: offset error %.2f mm (reprojection %.3f px)\n", ptz::sideName(side),
                1000 * error.norm(), estimate.reprojection_rms_px);
  }
  ptz::StereoRig unmodelled = rig;  // the same calibration with the optical centre on the pivot
  unmodelled.left.optical_centre_from_pivot_m.setZero();
  unmodelled.right.optical_centre_from_pivot_m.setZero();
  double worst = 0, worst_unmodelled = 0;
  int points = 0;
  for (double left_pan_deg : {-20.0, 20.0}) {
    for (double right_pan_deg : {-20.0, 20.0}) {
      const ptz::PtzPose lp{left_pan_deg * M_PI / 180, 0, 1}, rp{right_pan_deg * M_PI / 180, 0, 1};
      const ptz::CameraView tl = truth.view(ptz::Side::kLeft, lp),
                            tr = truth.view(ptz::Side::kRight, rp);
      for (int i = 0; i < 400; ++i) {
        const Eigen::Vector3d p(ptz::test::uniform(rng, -3, 3), ptz::test::uniform(rng, -0.5, 0.5),
                                ptz::test::uniform(rng, 1, 5));
        // Within 30 deg of both optical axes (further out the distortion polynomial folds back
        // into the image), and inside both images.
        const Eigen::Vector3d pl = tl.toCamera(p), pr = tr.toCamera(p);
        if (pl.z() < 0.87 * pl.norm() || pr.z() < 0.87 * pr.norm()) continue;
        const Eigen::Vector2d l = tl.project(p), r = tr.project(p);
        if (!(l.x() > 0 && l.x() < 640 && l.y() > 0 && l.y() < 480 && r.x() > 0 && r.x() < 640 &&
              r.y() > 0 && r.y() < 480)) {
          continue;
        }
        Eigen::Vector3d exact;  // rays too close to parallel even for the true rig: skip
        if (!ptz::perception::triangulate(tl, tr, l, r, &exact)) continue;
        const double range = p.norm();
        for (const ptz::StereoRig* model : {&rig, &unmodelled}) {
          Eigen::Vector3d q;
          ASSERT_TRUE(ptz::perception::triangulate(model->view(ptz::Side::kLeft, lp),
                                                   model->view(ptz::Side::kRight, rp), l, r, &q));
          double& w = model == &rig ? worst : worst_unmodelled;
          w = std::max(w, (q - p).norm() / range);
        }
        ++points;
      }
    }
  }
  ASSERT_GT(points, 100);
  EXPECT_LT(worst, 0.005);
  EXPECT_GT(worst_unmodelled, 0.02);  // the offset matters: the test would notice its absence
  std::printf(
      "panned +-20 deg, %d points at 1-5 m: worst error %.3f %% of range (%.3f %% with "
      "the optical centre on the pivot)\n",
      points, 100 * worst, 100 * worst_unmodelled);
}

}  // namespace
