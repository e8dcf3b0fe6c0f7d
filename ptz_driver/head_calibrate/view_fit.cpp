#include "ptz_driver/head_calibrate/view_fit.hpp"

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

namespace ptz::driver {

std::vector<cv::Point2f> findCorners(const cv::Mat& grey, int max_points) {
  // A share of the corners from each tile of a grid, each tile's threshold its own: one strong
  // edge in view (a plain object's rim at a high zoom, measured: 2 to 18 corners found again where
  // the backdrop offered hundreds) would leave a faint texture elsewhere below a whole image's.
  // A tile's threshold is still at least a thousandth of the whole image's best: a plain tile
  // offers no noise for corners.
  constexpr int kTiles = 4;
  const int per_tile = std::max(1, max_points / (kTiles * kTiles));
  cv::Mat strength;
  cv::cornerMinEigenVal(grey, strength, 5);
  double best = 0;
  cv::minMaxLoc(strength, nullptr, &best);
  std::vector<cv::Point2f> corners;
  for (int ty = 0; ty < kTiles; ++ty) {
    for (int tx = 0; tx < kTiles; ++tx) {
      const int x0 = tx * grey.cols / kTiles, y0 = ty * grey.rows / kTiles;
      const cv::Rect tile(x0, y0, (tx + 1) * grey.cols / kTiles - x0,
                          (ty + 1) * grey.rows / kTiles - y0);
      if (tile.width < 16 || tile.height < 16) continue;
      double tile_best = 0;
      cv::minMaxLoc(strength(tile), nullptr, &tile_best);
      if (!(tile_best > 0)) continue;
      const double quality = std::min(1.0, std::max(0.01, 1e-3 * best / tile_best));
      std::vector<cv::Point2f> found;
      cv::goodFeaturesToTrack(grey(tile), found, per_tile, quality, 10, cv::noArray(), 5);
      for (const auto& p : found) corners.push_back(p + cv::Point2f(tile.tl()));
    }
  }
  if (!corners.empty()) {
    cv::cornerSubPix(grey, corners, {5, 5}, {-1, -1},
                     {cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01});
  }
  return corners;
}

Tracks track(const cv::Mat& from_image, const cv::Mat& to_image,
             const std::vector<cv::Point2f>& points, const std::vector<cv::Point2f>& predicted) {
  Tracks t;
  if (points.empty()) return t;
  const cv::Size window(21, 21);
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 40, 0.005);
  std::vector<cv::Point2f> to = predicted.size() == points.size() ? predicted : points;
  std::vector<cv::Point2f> back = points;
  std::vector<uchar> ok_to, ok_back;
  std::vector<float> err;
  cv::calcOpticalFlowPyrLK(from_image, to_image, points, to, ok_to, err, window, 4, stop,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  cv::calcOpticalFlowPyrLK(to_image, from_image, to, back, ok_back, err, window, 4, stop,
                           cv::OPTFLOW_USE_INITIAL_FLOW);
  const cv::Rect2f inside(0, 0, static_cast<float>(to_image.cols - 1),
                          static_cast<float>(to_image.rows - 1));
  for (size_t i = 0; i < points.size(); ++i) {
    if (!ok_to[i] || !ok_back[i] || !inside.contains(to[i])) continue;
    if (cv::norm(back[i] - points[i]) > 0.3) continue;
    t.from.push_back(points[i]);
    t.to.push_back(to[i]);
    t.index.push_back(static_cast<int>(i));
  }
  return t;
}

double imageMotionPx(const Tracks& t) {
  if (t.from.size() < static_cast<size_t>(kMinFitPoints)) {
    return std::numeric_limits<double>::infinity();
  }
  const cv::Mat m = cv::estimateAffinePartial2D(t.from, t.to, cv::noArray(), cv::RANSAC, 1.0);
  if (m.empty()) return std::numeric_limits<double>::infinity();
  const cv::Matx23d a = m;
  double sum = 0;
  for (const cv::Point2f& p : t.from) {
    sum += std::hypot(a(0, 0) * p.x + a(0, 1) * p.y + a(0, 2) - p.x,
                      a(1, 0) * p.x + a(1, 1) * p.y + a(1, 2) - p.y);
  }
  return sum / t.from.size();
}

namespace {

// Camera-frame rays (z = 1) of distorted pixels of side's camera at zoom.
std::vector<Eigen::Vector3d> rays(const StereoRig& rig, Side side, double zoom,
                                  const std::vector<cv::Point2f>& pixels) {
  std::vector<Eigen::Vector3d> out;
  if (pixels.empty()) return out;
  const Intrinsics in = rig.camera(side).intrinsicsAt(zoom);
  const cv::Matx33d k(in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1);
  const std::vector<double> d(in.distortion.begin(), in.distortion.end());
  std::vector<cv::Point2f> normalised;
  cv::undistortPoints(pixels, normalised, k, d, cv::noArray(), cv::noArray(),
                      {cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-10});
  for (const auto& n : normalised) out.emplace_back(n.x, n.y, 1.0);
  return out;
}

// Gauss-Newton on n (1 or 2) parameters with numeric derivatives, then again on the points whose
// residual is within 3 medians (at least 0.5 px): a few mistracked corners do not pull the fit.
Fit robustFit(int n, const double* guess, size_t count,
              const std::function<Eigen::Vector2d(const double*, size_t)>& predict,
              const std::vector<cv::Point2f>& observed, double step) {
  Fit fit;
  if (count < static_cast<size_t>(kMinFitPoints)) {
    fit.why = "only " + std::to_string(count) + " corners were found again (at least " +
              std::to_string(kMinFitPoints) + ")";
    return fit;
  }
  double x[2] = {guess[0], n > 1 ? guess[1] : 0};
  std::vector<size_t> use(count);
  for (size_t i = 0; i < count; ++i) use[i] = i;
  for (int round = 0; round < 3; ++round) {
    for (int iteration = 0; iteration < 20; ++iteration) {
      Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(n, n);
      Eigen::VectorXd jtr = Eigen::VectorXd::Zero(n);
      for (size_t i : use) {
        const Eigen::Vector2d p = predict(x, i);
        if (!p.allFinite()) continue;
        const Eigen::Vector2d r = Eigen::Vector2d(observed[i].x, observed[i].y) - p;
        Eigen::Matrix<double, 2, Eigen::Dynamic> j(2, n);
        for (int k = 0; k < n; ++k) {
          double xk[2] = {x[0], x[1]};
          xk[k] -= step;  // backwards: a zoom at the table's top end has no step above it
          j.col(k) = (p - predict(xk, i)) / step;
        }
        jtj += j.transpose() * j;
        jtr += j.transpose() * r;
      }
      const Eigen::VectorXd dx = jtj.ldlt().solve(jtr);
      if (!dx.allFinite()) {
        fit.why = "the fit did not converge";
        return fit;
      }
      for (int k = 0; k < n; ++k) x[k] += dx[k];
      if (dx.norm() < step * 1e-3) break;
    }
    std::vector<double> norms;
    for (size_t i : use)
      norms.push_back((predict(x, i) - Eigen::Vector2d(observed[i].x, observed[i].y)).norm());
    std::vector<double> sorted = norms;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = std::max(0.5, 3 * sorted[sorted.size() / 2]);
    std::vector<size_t> kept;
    double sum_sq = 0;
    for (size_t k = 0; k < use.size(); ++k) {
      if (!(norms[k] <= limit)) continue;
      kept.push_back(use[k]);
      sum_sq += norms[k] * norms[k];
    }
    if (kept.size() < static_cast<size_t>(kMinFitPoints)) {
      fit.why = "only " + std::to_string(kept.size()) + " of " + std::to_string(count) +
                " corners agree on one motion (at least " + std::to_string(kMinFitPoints) + ")";
      return fit;
    }
    fit.rms_px = std::sqrt(sum_sq / kept.size());
    fit.inliers = static_cast<int>(kept.size());
    use = std::move(kept);
  }
  fit.ok = true;
  fit.value[0] = x[0];
  fit.value[1] = x[1];
  return fit;
}

}  // namespace

ScenePoints triangulateAtHome(const StereoRig& rig, Side side, double zoom, const cv::Mat& left,
                              const cv::Mat& right, int max_points) {
  const Side other = side == Side::kLeft ? Side::kRight : Side::kLeft;
  const cv::Mat& mine = side == Side::kLeft ? left : right;
  const cv::Mat& theirs = side == Side::kLeft ? right : left;
  const Tracks t = track(mine, theirs, findCorners(mine, max_points));
  const PtzPose home{0, 0, zoom};
  const CameraView a = rig.view(side, home), b = rig.view(other, home);
  const auto ray_a = rays(rig, side, zoom, t.from), ray_b = rays(rig, other, zoom, t.to);
  ScenePoints out;
  for (size_t i = 0; i < ray_a.size(); ++i) {
    const Eigen::Vector3d da = (a.rotation_head_camera * ray_a[i]).normalized();
    const Eigen::Vector3d db = (b.rotation_head_camera * ray_b[i]).normalized();
    const Eigen::Vector3d w = a.position_head_m - b.position_head_m;
    const double ab = da.dot(db), denominator = 1 - ab * ab;
    Eigen::Vector3d p = a.position_head_m + 200.0 * da;  // parallel: far
    if (denominator > 1e-12) {
      const double s = (ab * db.dot(w) - da.dot(w)) / denominator;
      const double u = (db.dot(w) - ab * da.dot(w)) / denominator;
      if (s <= 0.2 || u <= 0.2) continue;  // behind or at the cameras: a false match
      const Eigen::Vector3d mid = 0.5 * (a.position_head_m + s * da + b.position_head_m + u * db);
      if ((a.project(mid) - Eigen::Vector2d(t.from[i].x, t.from[i].y)).norm() > 1.0 ||
          (b.project(mid) - Eigen::Vector2d(t.to[i].x, t.to[i].y)).norm() > 1.0) {
        continue;  // the rays miss each other: not one point
      }
      if (s < 200) p = mid;
    }
    out.pixels.push_back(t.from[i]);
    out.points_head_m.push_back(p);
  }
  return out;
}

Fit fitPanTilt(const StereoRig& rig, Side side, double zoom,
               const std::vector<Eigen::Vector3d>& points_head_m,
               const std::vector<cv::Point2f>& observed, double pan_guess_rad,
               double tilt_guess_rad) {
  const double guess[2] = {pan_guess_rad, tilt_guess_rad};
  return robustFit(
      2, guess, observed.size(),
      [&](const double* x, size_t i) {
        return rig.view(side, PtzPose{x[0], x[1], zoom}).project(points_head_m[i]);
      },
      observed, 1e-6);
}

std::vector<cv::Point2f> zoomedPixels(const StereoRig& rig, Side side, double zoom_from,
                                      double zoom_to, const std::vector<cv::Point2f>& pixels) {
  const CameraView to = rig.view(side, PtzPose{0, 0, zoom_to});
  std::vector<cv::Point2f> out;
  for (const auto& r : rays(rig, side, zoom_from, pixels)) {
    const Eigen::Vector2d p = to.projectCamera(r);
    out.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }
  return out;
}

Fit fitZoom(const StereoRig& rig, Side side, double zoom_from, const std::vector<cv::Point2f>& from,
            const std::vector<cv::Point2f>& observed, double zoom_guess) {
  const std::vector<Eigen::Vector3d> r = rays(rig, side, zoom_from, from);
  const double guess[1] = {zoom_guess};
  return robustFit(
      1, guess, observed.size(),
      [&](const double* x, size_t i) {
        return rig.view(side, PtzPose{0, 0, x[0]}).projectCamera(r[i]);
      },
      observed, 1e-5);
}

}  // namespace ptz::driver
