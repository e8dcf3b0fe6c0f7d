#include "perception/ptz_calibration.hpp"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <map>
#include <sstream>

namespace ptz::perception {

std::vector<ZoomEntry> calibrateZoomTable(const std::vector<ZoomViews>& zooms,
                                          const BoardSpec& board, cv::Size image_size,
                                          int min_views) {
  std::vector<ZoomEntry> table;
  double widest = 1e300;
  for (const ZoomViews& z : zooms) widest = std::min(widest, z.zoom);
  for (const ZoomViews& z : zooms) {
    std::ostringstream what;
    what << "zoom " << z.zoom;
    if (static_cast<int>(z.corners_px.size()) < min_views) {
      throw CalibrationError(what.str() +
                             ": too few views: " + std::to_string(z.corners_px.size()) +
                             ", need at least " + std::to_string(min_views));
    }
    const std::vector<std::vector<cv::Point3f>> object(z.corners_px.size(), boardPoints(board));
    // Zoomed in, the field of view narrows and k3 is no longer separable from k1, k2.
    const int flags = z.zoom > widest ? cv::CALIB_FIX_K3 : 0;
    const MonoCalibration m = calibrateMono(object, z.corners_px, image_size, flags, what.str());
    table.push_back({z.zoom, m.intrinsics()});
  }
  std::sort(table.begin(), table.end(),
            [](const ZoomEntry& a, const ZoomEntry& b) { return a.zoom < b.zoom; });
  for (size_t i = 1; i < table.size(); ++i) {
    if (table[i].zoom <= table[i - 1].zoom) {
      throw CalibrationError("zoom " + std::to_string(table[i].zoom) + " given twice");
    }
  }
  return table;
}

PivotEstimate estimateOpticalCentreFromPivot(const std::vector<PivotView>& views,
                                             const BoardSpec& board, const Intrinsics& k) {
  std::map<int, int> station_index;
  for (const auto& v : views) station_index.emplace(v.station, 0);
  int next = 0;
  for (auto& [station, index] : station_index) index = next++;
  const int unknowns = 3 + 3 * next;
  const int rows = 3 * static_cast<int>(views.size());
  if (rows < unknowns + 3) {
    throw CalibrationError("pan/tilt kinematics: " + std::to_string(views.size()) +
                           " views are too few for " + std::to_string(next) + " board station(s)");
  }
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  const cv::Mat D(k.distortion, true);
  const std::vector<cv::Point3f> object = boardPoints(board);
  cv::Mat A = cv::Mat::zeros(rows, unknowns, CV_64F), b(rows, 1, CV_64F);
  for (size_t i = 0; i < views.size(); ++i) {
    cv::Mat rvec, tvec, R;
    cv::solvePnP(object, views[i].corners_px, K, D, rvec, tvec);
    cv::Rodrigues(rvec, R);  // x_camera = R x_board + t
    const cv::Mat R_board_camera = R.t();
    const cv::Mat centre = -R_board_camera * tvec;
    const int row = 3 * static_cast<int>(i);
    const int p = 3 + 3 * station_index[views[i].station];
    R_board_camera.copyTo(A(cv::Rect(0, row, 3, 3)));
    A(cv::Rect(p, row, 3, 3)) = cv::Mat::eye(3, 3, CV_64F);
    centre.copyTo(b.rowRange(row, row + 3));
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(A, w, u, vt);
  if (w.at<double>(unknowns - 1) < 1e-3 * w.at<double>(0)) {
    throw CalibrationError(
        "pan/tilt kinematics: the offset of the optical centre is not observable from these "
        "views; take views at several pans and several tilts of each board station");
  }
  cv::Mat x;
  cv::solve(A, b, x, cv::DECOMP_SVD);
  PivotEstimate e;
  e.optical_centre_from_pivot_m = {x.at<double>(0), x.at<double>(1), x.at<double>(2)};
  e.residual_rms_m = cv::norm(A * x - b) / std::sqrt(static_cast<double>(views.size()));
  return e;
}

}  // namespace ptz::perception
