#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <map>

#include "perception/calibrate/ptz_calibration.hpp"

namespace ptz::perception {
namespace {

// Q = Ry(pan) Rx(tilt): the camera's rotation from its home orientation (the rig's kinematics).
cv::Mat panTilt(const PivotView& v) {
  const Eigen::Matrix3d q = rotationY(v.pan_rad) * rotationX(v.tilt_rad);
  cv::Mat Q(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) Q.at<double>(r, c) = q(r, c);
  }
  return Q;
}

// Corners of every view reprojected from: the offset o, and per station the board's pose seen
// from the camera at home (rotation vector of R_home_board, pivot position P in the board
// frame). View i: R_board_camera = R_home_board^T Q_i, centre = P + R_board_camera o.
class PivotReprojection : public cv::LMSolver::Callback {
 public:
  PivotReprojection(const std::vector<PivotView>& views,
                    std::vector<std::vector<cv::Point2f>> corners, std::vector<int> station,
                    std::vector<cv::Point3f> object, cv::Matx33d K, cv::Mat D)
      : corners_(std::move(corners)),
        station_(std::move(station)),
        object_(std::move(object)),
        K_(K),
        D_(std::move(D)) {
    for (const auto& v : views) Q_.push_back(panTilt(v));
  }

  bool compute(cv::InputArray param, cv::OutputArray err, cv::OutputArray J) const override {
    const cv::Mat p = param.getMat();
    const cv::Mat e = residuals(p);
    e.copyTo(err);
    if (J.needed()) {  // forward differences: a few dozen parameters at most
      J.create(e.rows, p.rows, CV_64F);
      cv::Mat jac = J.getMat();
      for (int j = 0; j < p.rows; ++j) {
        cv::Mat q = p.clone();
        q.at<double>(j) += 1e-7;
        cv::Mat column = (residuals(q) - e) / 1e-7;
        column.copyTo(jac.col(j));
      }
    }
    return true;
  }

 private:
  cv::Mat residuals(const cv::Mat& p) const {
    cv::Mat out(static_cast<int>(2 * corners_.size() * object_.size()), 1, CV_64F);
    const cv::Mat o = p.rowRange(0, 3);
    int row = 0;
    for (size_t i = 0; i < corners_.size(); ++i) {
      const int s = 3 + 6 * station_[i];
      cv::Mat R_home_board;
      cv::Rodrigues(p.rowRange(s, s + 3), R_home_board);
      const cv::Mat R_board_camera = R_home_board.t() * Q_[i];
      const cv::Mat centre = p.rowRange(s + 3, s + 6) + R_board_camera * o;
      const cv::Mat R_camera_board = R_board_camera.t();
      cv::Mat rvec;
      cv::Rodrigues(R_camera_board, rvec);
      std::vector<cv::Point2f> projected;
      cv::projectPoints(object_, rvec, cv::Mat(-R_camera_board * centre), K_, D_, projected);
      for (size_t k = 0; k < projected.size(); ++k) {
        out.at<double>(row++) = projected[k].x - corners_[i][k].x;
        out.at<double>(row++) = projected[k].y - corners_[i][k].y;
      }
    }
    return out;
  }

  std::vector<std::vector<cv::Point2f>> corners_;
  std::vector<int> station_;
  std::vector<cv::Point3f> object_;
  cv::Matx33d K_;
  cv::Mat D_;
  std::vector<cv::Mat> Q_;
};

}  // namespace

PivotEstimate estimateOpticalCentreFromPivot(const std::vector<PivotView>& views,
                                             const BoardSpec& board, const Intrinsics& k) {
  if (views.empty()) throw CalibrationError("pan/tilt kinematics: no views");
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
  std::map<int, const std::vector<cv::Point2f>*> first_of_station;
  std::vector<std::vector<cv::Point2f>> aligned;
  std::vector<cv::Mat> R_board_camera_pnp;
  for (size_t i = 0; i < views.size(); ++i) {
    // The same corner order in every view of a station (OpenCV may start from either end), or
    // a pose comes out turned by 180 deg about the board's normal.
    std::vector<cv::Point2f> corners = views[i].corners_px;
    const auto* first =
        first_of_station.emplace(views[i].station, &views[i].corners_px).first->second;
    alignCornerOrder(*first, &corners);
    cv::Mat rvec, tvec, R;
    cv::solvePnP(object, corners, K, D, rvec, tvec);
    cv::Rodrigues(rvec, R);  // x_camera = R x_board + t
    const cv::Mat R_board_camera = R.t();
    aligned.push_back(corners);
    R_board_camera_pnp.push_back(R_board_camera);
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
  const bool angles_known = std::all_of(views.begin(), views.end(), [](const PivotView& v) {
    return std::isfinite(v.pan_rad) && std::isfinite(v.tilt_rad);
  });
  if (!angles_known) return e;
  // With the pan/tilt angles known, only the board's pose per station and the offset are free:
  // refine them on the reprojection error of every corner.
  std::vector<int> station_of_view;
  for (const auto& v : views) station_of_view.push_back(station_index[v.station]);
  cv::Mat params(3 + 6 * next, 1, CV_64F);
  params.at<double>(0) = x.at<double>(0);
  params.at<double>(1) = x.at<double>(1);
  params.at<double>(2) = x.at<double>(2);
  for (int s = 0; s < next; ++s) {
    // Home orientation of the station: the chordal mean over its views of R_board_camera Q^T.
    cv::Mat sum = cv::Mat::zeros(3, 3, CV_64F);
    for (size_t i = 0; i < views.size(); ++i) {
      if (station_of_view[i] == s) sum += R_board_camera_pnp[i] * panTilt(views[i]).t();
    }
    cv::Mat w2, u2, vt2, rvec;
    cv::SVD::compute(sum, w2, u2, vt2);
    cv::Rodrigues((u2 * vt2).t(), rvec);  // R_home_board
    rvec.copyTo(params.rowRange(3 + 6 * s, 6 + 6 * s));
    x.rowRange(3 + 3 * s, 6 + 3 * s).copyTo(params.rowRange(6 + 6 * s, 9 + 6 * s));
  }
  auto callback = cv::makePtr<PivotReprojection>(views, aligned, station_of_view, object, K, D);
  cv::LMSolver::create(callback, 200, 1e-12)->run(params);
  cv::Mat residuals;
  callback->compute(params, residuals, cv::noArray());
  e.optical_centre_from_pivot_m = {params.at<double>(0), params.at<double>(1),
                                   params.at<double>(2)};
  e.reprojection_rms_px = std::sqrt(cv::norm(residuals, cv::NORM_L2SQR) / (residuals.total() / 2));
  return e;
}

}  // namespace ptz::perception
