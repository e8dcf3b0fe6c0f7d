// What a PTZ rig needs beyond a fixed stereo calibration: intrinsics per zoom position (the rig's
// zoom table) and where the optical centre sits relative to the pan/tilt pivot (the rig's
// optical_centre_from_pivot_m). No LCM.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <limits>
#include <vector>

#include "common/rig.hpp"
#include "perception/calibrate/calibration.hpp"

namespace ptz::perception {

// Board corners seen by one camera at one zoom position (each entry one view).
struct ZoomViews {
  double zoom = 1;
  std::vector<std::vector<cv::Point2f>> corners_px;
};

// A mono calibration at one zoom position. `widest`: the intrinsics at the widest zoom when this
// one is zoomed in; the narrower field of view then leaves k3 and the principal point poorly
// determined, so k3 is fixed at 0 and c at the widest zoom's. Throws CalibrationError naming the
// zoom.
MonoCalibration calibrateAtZoom(const ZoomViews& views, const BoardSpec& board, cv::Size image_size,
                                const Intrinsics* widest, int min_views = 8);

// A mono calibration per zoom position, sorted by zoom: the rig's zoom table (f, c and the
// 5-coefficient distortion per entry; c of every entry that of the widest).
std::vector<ZoomEntry> calibrateZoomTable(const std::vector<ZoomViews>& zooms,
                                          const BoardSpec& board, cv::Size image_size,
                                          int min_views = 8);

// Puts the entry into the camera's zoom table, replacing one at the same zoom, kept sorted.
void setZoomEntry(CameraSpec* camera, const ZoomEntry& entry);

// One view of a static board by one camera at some pan/tilt; `station` numbers the board's
// placements (the board must not move between views of one station).
struct PivotView {
  int station = 0;
  std::vector<cv::Point2f> corners_px;
  // The camera's pan and tilt at the view, when known (encoders, STEREO_FRAME, an image list).
  double pan_rad = std::numeric_limits<double>::quiet_NaN();
  double tilt_rad = std::numeric_limits<double>::quiet_NaN();
};

struct PivotEstimate {
  Eigen::Vector3d optical_centre_from_pivot_m = Eigen::Vector3d::Zero();  // camera frame
  double residual_rms_m = 0;  // camera centres against the linear model
  double reprojection_rms_px = std::numeric_limits<double>::quiet_NaN();  // refined, angles known
};

// The camera turns about axes through one pivot, so its centre in the board frame is
// C_i = P_station + R_i o, with R_i the camera's orientation (board frame) at view i: linear in
// the pivot P and the offset o. Each view's pose comes from cv::solvePnP with `intrinsics`.
// When every view's pan and tilt are known, the board pose per station and o are then refined on
// the reprojection error (cv::LMSolver): the views' rotations come from the angles, not from
// solvePnP, which is far less noisy. Needs views at several pans and tilts; throws
// CalibrationError when o is not observable.
PivotEstimate estimateOpticalCentreFromPivot(const std::vector<PivotView>& views,
                                             const BoardSpec& board, const Intrinsics& intrinsics);

}  // namespace ptz::perception
