#include "perception/calibrate/calibration.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace ptz::perception {

std::string BoardSpec::text() const {
  std::ostringstream s;
  s << inner_cols << "x" << inner_rows << " inner corners, " << square_m << " m squares";
  return s.str();
}

std::vector<cv::Point3f> boardPoints(const BoardSpec& board) {
  std::vector<cv::Point3f> points;
  for (int r = 0; r < board.inner_rows; ++r) {
    for (int c = 0; c < board.inner_cols; ++c) {
      points.emplace_back(static_cast<float>(c * board.square_m),
                          static_cast<float>(r * board.square_m), 0.f);
    }
  }
  return points;
}

bool findCorners(const cv::Mat& image, const BoardSpec& board,
                 std::vector<cv::Point2f>* corners_px) {
  cv::Mat gray = image;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  // FAST_CHECK rejects images without a board quickly (a live source sees many of them).
  const int flags =
      cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK;
  if (!cv::findChessboardCorners(gray, board.size(), *corners_px, flags)) return false;
  // A refinement window wider than a square converges on a neighbouring corner: fit it to the
  // smallest square seen (11 at most, OpenCV's sample value).
  double nearest_px = 1e9;
  const auto& c = *corners_px;
  for (int r = 0; r < board.inner_rows; ++r) {
    for (int k = 0; k < board.inner_cols; ++k) {
      const size_t i = static_cast<size_t>(r * board.inner_cols + k);
      if (k + 1 < board.inner_cols) nearest_px = std::min(nearest_px, cv::norm(c[i + 1] - c[i]));
      if (r + 1 < board.inner_rows) {
        nearest_px =
            std::min(nearest_px, cv::norm(c[i + static_cast<size_t>(board.inner_cols)] - c[i]));
      }
    }
  }
  const int half = std::clamp(static_cast<int>(0.4 * nearest_px), 2, 11);
  cv::cornerSubPix(gray, *corners_px, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01));
  return true;
}

void alignCornerOrder(const std::vector<cv::Point2f>& left, std::vector<cv::Point2f>* right) {
  if (left.size() < 2 || right->size() != left.size()) return;
  const cv::Point2f dl = left.back() - left.front(), dr = right->back() - right->front();
  if (dl.dot(dr) < 0) std::reverse(right->begin(), right->end());
}

Intrinsics MonoCalibration::intrinsics() const {
  Intrinsics k{K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2), {}};
  for (int i = 0; i < 5; ++i) k.distortion[static_cast<size_t>(i)] = D.at<double>(i);
  return k;
}

namespace {

double tiltDeg(const cv::Mat& rvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  return std::acos(std::min(1.0, std::abs(R.at<double>(2, 2)))) * 180 / M_PI;
}

std::string viewName(const ViewPair& v) {
  return v.left_name + " / " + v.right_name;
}

}  // namespace

MonoCalibration calibrateMono(const std::vector<std::vector<cv::Point3f>>& object_points,
                              const std::vector<std::vector<cv::Point2f>>& image_points,
                              cv::Size image_size, int flags, const std::string& what,
                              const cv::Mat& K_guess, const cv::Mat& D_guess) {
  MonoCalibration m;
  m.K = K_guess.empty() ? cv::Mat::eye(3, 3, CV_64F) : K_guess.clone();
  m.D = D_guess.empty() ? cv::Mat::zeros(1, 5, CV_64F) : D_guess.clone();
  cv::Mat std_intrinsics, std_extrinsics, view_errors;
  try {
    m.rms_px = cv::calibrateCamera(object_points, image_points, image_size, m.K, m.D, m.rvecs,
                                   m.tvecs, std_intrinsics, std_extrinsics, view_errors, flags);
  } catch (const cv::Exception& e) {
    throw CalibrationError(what + ": calibration failed, the views are probably degenerate (" +
                           e.err + ")");
  }
  if (!cv::checkRange(m.K) || !cv::checkRange(m.D) || m.K.at<double>(0, 0) <= 0) {
    throw CalibrationError(what + ": calibration gave no finite camera matrix (degenerate views)");
  }
  m.D = m.D.reshape(1, 1).colRange(0, 5).clone();
  view_errors.reshape(1, 1).copyTo(m.view_rms_px);
  for (const auto& r : m.rvecs) m.tilt_deg.push_back(tiltDeg(r));
  return m;
}

StereoRig StereoCalibration::toRig(double zoom) const {
  StereoRig rig;
  for (Side side : {Side::kLeft, Side::kRight}) {
    CameraSpec& spec = side == Side::kLeft ? rig.left : rig.right;
    spec.width = image_size.width;
    spec.height = image_size.height;
    spec.zoom_table = {{zoom, (side == Side::kLeft ? left : right).intrinsics()}};
  }
  for (int r = 0; r < 3; ++r) {
    rig.home.T[r] = T.at<double>(r);
    for (int c = 0; c < 3; ++c) rig.home.R(r, c) = R.at<double>(r, c);
  }
  return rig;
}

namespace {

double meanRectifiedEpipolarPx(const std::vector<ViewPair>& views, const StereoCalibration& c) {
  double sum = 0;
  size_t n = 0;
  for (const auto& v : views) {
    std::vector<cv::Point2f> l, r;
    cv::undistortPoints(v.left_px, l, c.left.K, c.left.D, c.R1, c.P1);
    cv::undistortPoints(v.right_px, r, c.right.K, c.right.D, c.R2, c.P2);
    for (size_t i = 0; i < l.size(); ++i, ++n) sum += std::abs(l[i].y - r[i].y);
  }
  return n ? sum / static_cast<double>(n) : 0;
}

}  // namespace

std::string utcNow() {
  const std::time_t now = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  return text;
}

StereoCalibration calibrateStereo(const std::vector<ViewPair>& views, const BoardSpec& board,
                                  cv::Size image_size, const StereoOptions& options) {
  if (static_cast<int>(views.size()) < options.min_views) {
    std::string names;
    for (const auto& v : views) names += "\n  " + viewName(v);
    throw CalibrationError("too few views: " + std::to_string(views.size()) +
                           " with the board found in both images, need at least " +
                           std::to_string(options.min_views) + " (min_views)" + names);
  }
  StereoCalibration c;
  c.board = board;
  c.image_size = image_size;
  c.date_utc = utcNow();
  const std::vector<std::vector<cv::Point3f>> object(views.size(), boardPoints(board));
  std::vector<std::vector<cv::Point2f>> left_px, right_px;
  for (const auto& v : views) {
    left_px.push_back(v.left_px);
    right_px.push_back(v.right_px);
  }
  const auto stage = [&](const std::string& line) {
    if (options.progress) options.progress(line, true);
  };
  stage("mono calibration, left camera: " + std::to_string(views.size()) + " views...");
  c.left = calibrateMono(object, left_px, image_size, 0, "left camera");
  stage("mono calibration, right camera: " + std::to_string(views.size()) + " views...");
  c.right = calibrateMono(object, right_px, image_size, 0, "right camera");
  // Fronto-parallel views leave the focal length unobservable (Zhang): refuse, do not guess.
  const double max_tilt_deg = *std::max_element(c.left.tilt_deg.begin(), c.left.tilt_deg.end());
  if (max_tilt_deg < options.min_tilt_deg) {
    std::ostringstream s;
    s << "degenerate views: the board is nearly fronto-parallel in every view (largest tilt "
      << max_tilt_deg << " deg < min_tilt_deg " << options.min_tilt_deg
      << "), so the focal length is not observable; tilt the board by 20-45 deg in some views ("
      << viewName(views.front()) << " ... " << viewName(views.back()) << ")";
    throw CalibrationError(s.str());
  }
  cv::Mat view_errors;
  stage("stereo calibration (R, T" +
        std::string(options.refine_intrinsics ? " and both cameras' intrinsics" : "") + ")...");
  c.stereo_rms_px = cv::stereoCalibrate(
      object, left_px, right_px, c.left.K, c.left.D, c.right.K, c.right.D, image_size, c.R, c.T,
      c.E, c.F, view_errors,
      options.refine_intrinsics ? cv::CALIB_USE_INTRINSIC_GUESS : cv::CALIB_FIX_INTRINSIC,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-6));
  std::vector<ViewPair> kept;
  for (size_t i = 0; i < views.size(); ++i) {
    const int row = static_cast<int>(i);
    ViewReport r{views[i].left_name, views[i].right_name, view_errors.at<double>(row, 0),
                 view_errors.at<double>(row, 1), c.left.tilt_deg[i]};
    const double worst = std::max(r.left_rms_px, r.right_rms_px);
    if (worst > options.max_view_error_px) {
      std::ostringstream s;
      s << "per-view error " << worst << " px > max_view_error_px " << options.max_view_error_px;
      c.outliers.push_back(viewName(views[i]) + ": " + s.str());
      if (options.drop_outliers) {
        c.dropped.push_back({viewName(views[i]), s.str()});
        continue;
      }
    }
    kept.push_back(views[i]);
    c.views.push_back(r);
  }
  if (!c.dropped.empty()) {
    if (static_cast<int>(kept.size()) < options.min_views) {
      throw CalibrationError(
          "dropping the " + std::to_string(c.dropped.size()) + " views above max_view_error_px " +
          std::to_string(options.max_view_error_px) + " px would leave " +
          std::to_string(kept.size()) + ", fewer than min_views " +
          std::to_string(options.min_views) +
          ": raise max_view_error_px or take more views (worst: " + c.outliers.front() + ")");
    }
    stage("again without the " + std::to_string(c.dropped.size()) + " outlier views");
    StereoOptions again = options;
    again.drop_outliers = false;
    StereoCalibration refit = calibrateStereo(kept, board, image_size, again);
    refit.dropped = c.dropped;
    refit.outliers = c.outliers;
    return refit;
  }
  stage("rectification...");
  cv::stereoRectify(c.left.K, c.left.D, c.right.K, c.right.D, image_size, c.R, c.T, c.R1, c.R2,
                    c.P1, c.P2, c.Q, cv::CALIB_ZERO_DISPARITY, options.rectify_alpha);
  c.rectified_epipolar_px = meanRectifiedEpipolarPx(views, c);
  return c;
}

}  // namespace ptz::perception
