#include "perception/depth/depth.hpp"

#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc/disparity_filter.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>

#include "common/config.hpp"
#include "perception/depth/remap.hpp"

namespace ptz::perception {

MatcherParams::Mode MatcherParams::parseMode(const std::string& name) {
  if (name == "bm") return Mode::kBm;
  if (name == "sgbm") return Mode::kSgbm;
  throw ConfigError("parameter 'mode': '" + name + "' is neither bm nor sgbm");
}

const char* MatcherParams::modeName(Mode mode) {
  return mode == Mode::kBm ? "bm" : "sgbm";
}

DisparityMatcher::DisparityMatcher(MatcherParams p) : params_(std::move(p)) {
  const auto& m = params_;
  if (m.num_disparities <= 0 || m.num_disparities % 16 != 0) {
    throw ConfigError("parameter 'num_disparities' must be a positive multiple of 16");
  }
  if (m.mode == MatcherParams::Mode::kBm) {
    if (m.block_size_px < 5 || m.block_size_px % 2 == 0) {
      throw ConfigError("parameter 'block_size_px' must be odd and >= 5");
    }
    auto bm = cv::StereoBM::create(m.num_disparities, m.block_size_px);
    // The paper's pre-filter: the image normalised over a small window.
    bm->setPreFilterType(cv::StereoBM::PREFILTER_NORMALIZED_RESPONSE);
    bm->setPreFilterSize(m.prefilter_size_px);
    bm->setPreFilterCap(m.prefilter_cap);
    bm->setTextureThreshold(m.texture_threshold);
    bm->setUniquenessRatio(m.uniqueness_pct);
    matcher_ = bm;
  } else {
    const int b = m.sgbm_block_size_px;
    if (b < 1 || b % 2 == 0) throw ConfigError("parameter 'sgbm_block_size_px' must be odd");
    // OpenCV's recommended smoothness penalties for one channel; HH4 (4 paths) was the best
    // of the modes on the Middlebury sets.
    matcher_ =
        cv::StereoSGBM::create(0, m.num_disparities, b, 8 * b * b, 32 * b * b, -1, m.prefilter_cap,
                               m.uniqueness_pct, 0, 0, cv::StereoSGBM::MODE_HH4);
  }
  // Left-right consistency from the cost volume, inside OpenCV (no second pass).
  matcher_->setDisp12MaxDiff(m.lr_max_diff_px);
  matcher_->setSpeckleWindowSize(m.speckle_window_px);
  matcher_->setSpeckleRange(m.speckle_range_px);
  if (m.wls) {
    wls_ = cv::ximgproc::createDisparityWLSFilter(matcher_);
    wls_->setLambda(m.wls_lambda);
    wls_->setSigmaColor(m.wls_sigma);
    right_matcher_ = cv::ximgproc::createRightMatcher(matcher_);
  }
}

void DisparityMatcher::compute(const cv::Mat& left_gray, const cv::Mat& right_gray,
                               int min_disparity_px, cv::Mat* disparity_16s) {
  if (params_.full_width) {
    // OpenCV leaves the columns where the whole range does not fit invalid: widen the images
    // by the range, match, and cut the disparity back to the original columns.
    const int left = std::max(min_disparity_px + params_.num_disparities, 0);
    const int right = std::max(-min_disparity_px, 0);
    cv::copyMakeBorder(left_gray, left_pad_, 0, 0, left, right, cv::BORDER_REPLICATE);
    cv::copyMakeBorder(right_gray, right_pad_, 0, 0, left, right, cv::BORDER_REPLICATE);
    match(left_pad_, right_pad_, min_disparity_px, &disp_pad_);
    disp_pad_.colRange(left, left + left_gray.cols).copyTo(*disparity_16s);
    return;
  }
  match(left_gray, right_gray, min_disparity_px, disparity_16s);
}

void DisparityMatcher::match(const cv::Mat& left_gray, const cv::Mat& right_gray,
                             int min_disparity_px, cv::Mat* disparity_16s) {
  matcher_->setMinDisparity(min_disparity_px);
  if (!wls_) {
    matcher_->compute(left_gray, right_gray, *disparity_16s);
    return;
  }
  cv::Mat left_disp, right_disp;
  right_matcher_->setMinDisparity(-(min_disparity_px + params_.num_disparities) + 1);
  matcher_->compute(left_gray, right_gray, left_disp);
  right_matcher_->compute(right_gray, left_gray, right_disp);
  wls_.dynamicCast<cv::ximgproc::DisparityWLSFilter>()->filter(left_disp, left_gray, *disparity_16s,
                                                               right_disp);
}

double Rectification::disparityOf(const Eigen::Vector3d& p_head) const {
  const Eigen::Vector3d p = rotation_head_rect.transpose() * (p_head - position_head_m);
  if (!(p.z() > 0)) return std::numeric_limits<double>::quiet_NaN();
  const double xl = P1.at<double>(0, 0) * p.x() / p.z() + P1.at<double>(0, 2);
  const double xr =
      (P2.at<double>(0, 0) * p.x() + P2.at<double>(0, 3)) / p.z() + P2.at<double>(0, 2);
  return xl - xr;
}

double Rectification::disparityAtDepth(double depth_m) const {
  return P1.at<double>(0, 2) - P2.at<double>(0, 2) - P2.at<double>(0, 3) / depth_m;
}

double Rectification::depthAtDisparity(double disparity_px) const {
  return -P2.at<double>(0, 3) / (disparity_px - (P1.at<double>(0, 2) - P2.at<double>(0, 2)));
}

namespace {

bool calibrated(const CameraSpec& spec, const PtzPose& pose) {
  return std::isfinite(pose.pan_rad) && std::isfinite(pose.tilt_rad) && std::isfinite(pose.zoom) &&
         pose.zoom >= spec.minZoom() - 1e-9 && pose.zoom <= spec.maxZoom() + 1e-9;
}

bool samePose(const PtzPose& a, const PtzPose& b) {
  // Below this an angle moves the image by < 0.01 px even at 10x zoom: not worth new maps.
  constexpr double kAngleTol = 1e-6, kZoomTol = 1e-6;
  return std::abs(a.pan_rad - b.pan_rad) < kAngleTol &&
         std::abs(a.tilt_rad - b.tilt_rad) < kAngleTol && std::abs(a.zoom - b.zoom) < kZoomTol;
}

cv::Mat cameraMatrix(const Intrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

}  // namespace

int decimationFor(int width_px, int max_width_px) {
  if (max_width_px <= 0 || width_px <= max_width_px) return 1;
  return (width_px + max_width_px - 1) / max_width_px;
}

StereoRig decimatedRig(const StereoRig& rig, int factor) {
  StereoRig d = rig;
  if (factor <= 1) return d;
  for (CameraSpec* c : {&d.left, &d.right}) {
    for (ZoomEntry& z : c->zoom_table) {
      Intrinsics& k = z.intrinsics;
      k.fx /= factor;
      k.fy /= factor;
      k.cx = (k.cx + 0.5) / factor - 0.5;
      k.cy = (k.cy + 0.5) / factor - 0.5;
    }
    c->width /= factor;
    c->height /= factor;
  }
  return d;
}

Rectifier::Rectifier(StereoRig rig, int decimation)
    : rig_(std::move(rig)), matched_rig_(decimatedRig(rig_, decimation)), decimation_(decimation) {
  if (decimation < 1) throw ConfigError("decimation must be >= 1");
}

bool Rectifier::update(const PtzPose& left, const PtzPose& right, std::string* why) {
  for (Side side : {Side::kLeft, Side::kRight}) {
    const CameraSpec& spec = rig_.camera(side);
    const PtzPose& pose = side == Side::kLeft ? left : right;
    if (!calibrated(spec, pose)) {
      *why = std::string(sideName(side)) + " camera at pan " + std::to_string(pose.pan_rad) +
             ", tilt " + std::to_string(pose.tilt_rad) + ", zoom " + std::to_string(pose.zoom) +
             ": outside the calibrated zoom table [" + std::to_string(spec.minZoom()) + ", " +
             std::to_string(spec.maxZoom()) + "] or not finite";
      return false;
    }
  }
  if (pose_ && samePose(pose_->first, left) && samePose(pose_->second, right)) return true;
  const CameraView lv = matched_rig_.view(Side::kLeft, left);
  const CameraView rv = matched_rig_.view(Side::kRight, right);
  const StereoExtrinsics e = matched_rig_.extrinsics(left, right);
  const cv::Mat K1 = cameraMatrix(lv.intrinsics), K2 = cameraMatrix(rv.intrinsics);
  const cv::Mat D1(lv.intrinsics.distortion, true), D2(rv.intrinsics.distortion, true);
  cv::Mat R, T;
  cv::eigen2cv(e.R, R);
  cv::eigen2cv(e.T, T);
  const cv::Size size(lv.width, lv.height);
  Rectification& r = rect_;
  r.size = size;
  r.decimation = decimation_;
  // No CALIB_ZERO_DISPARITY: vergent cameras keep their image content, so points beyond the
  // fixation point get negative disparities (the horopter handles them).
  cv::stereoRectify(K1, D1, K2, D2, size, R, T, r.R1, r.R2, r.P1, r.P2, r.Q, 0, -1, size);
  cv::initUndistortRectifyMap(K1, D1, r.R1, r.P1, size, CV_16SC2, r.map_left[0], r.map_left[1]);
  cv::initUndistortRectifyMap(K2, D2, r.R2, r.P2, size, CV_16SC2, r.map_right[0], r.map_right[1]);
  Eigen::Matrix3d R1;
  cv::cv2eigen(r.R1, R1);
  r.rotation_head_rect = lv.rotation_head_camera * R1.transpose();
  r.position_head_m = lv.position_head_m;
  pose_ = std::make_pair(left, right);
  ++rebuilds_;
  return true;
}

int chooseMinDisparity(const Rectification& rect, const HoropterParams& p, int num_disparities,
                       const std::optional<Eigen::Vector3d>& target_head_m) {
  if (p.follow_target && target_head_m) {
    const double d = rect.disparityOf(*target_head_m);
    if (std::isfinite(d)) return static_cast<int>(std::floor(d)) - num_disparities / 2;
  }
  if (p.far_depth_m > 0) return static_cast<int>(std::floor(rect.disparityAtDepth(p.far_depth_m)));
  return p.min_disparity_px;
}

DepthEstimator::DepthEstimator(StereoRig rig, DepthParams params)
    : params_(std::move(params)),
      rectifier_(rig, decimationFor(rig.left.width, params_.match_max_width_px)),
      matcher_(params_.matcher) {
  if (params_.cloud_stride_px < 1) throw ConfigError("parameter 'cloud_stride_px' must be >= 1");
  if (!(params_.min_depth_m > 0) || !(params_.max_depth_m > params_.min_depth_m)) {
    throw ConfigError("parameters 'min_depth_m', 'max_depth_m': need 0 < min < max");
  }
  if (params_.match_max_width_px < 0) {
    throw ConfigError("parameter 'match_max_width_px' must be >= 0");
  }
}

void DepthEstimator::rectifyPair(const cv::Mat& left_bgr, const cv::Mat& right_bgr) {
  const Rectification& r = rectifier_.current();
  const int f = r.decimation;
  const cv::Mat* bgr[2] = {&left_bgr, &right_bgr};
  cv::Mat* grey[2] = {&left_grey_, &right_grey_};
  cv::Mat* small[2] = {&left_small_, &right_small_};
  const cv::Mat* map[2][2] = {{&r.map_left[0], &r.map_left[1]}, {&r.map_right[0], &r.map_right[1]}};
  cv::Mat* rectified[2] = {&left_rect_, &right_rect_};
  for (int k = 0; k < 2; ++k) {
    grey[k]->create(bgr[k]->size(), CV_8UC1);
    // Whole f x f blocks, the decimated rig's pixels; a remainder of rows or columns is cropped.
    if (f > 1) small[k]->create(bgr[k]->rows / f, bgr[k]->cols / f, CV_8UC1);
    rectified[k]->create(map[k][0]->size(), CV_8UC1);
  }
  // Two passes over stripes of both images, one parallel region each (OpenCV runs the calls
  // inside on one thread): grey before remapping, so that the remap interpolates one channel
  // instead of three, and the decimation; then the remap.
  constexpr int kStripes = 8;  // per image
  const int sample_task = 2 * kStripes;
  cv::parallel_for_(cv::Range(0, sample_task + 1), [&](const cv::Range& tasks) {
    for (int t = tasks.start; t < tasks.end; ++t) {
      if (t == sample_task) {
        // The samples' colours (scattered reads) from the input image.
        cv::remap(left_bgr, sample_bgr_, sample_map_[0], sample_map_[1], cv::INTER_LINEAR);
        continue;
      }
      const int k = t / kStripes, stripe = t % kStripes, rows = bgr[k]->rows / f;
      const int y0 = rows * stripe / kStripes, y1 = rows * (stripe + 1) / kStripes;
      cv::Mat g = grey[k]->rowRange(y0 * f, y1 * f);
      cv::cvtColor(bgr[k]->rowRange(y0 * f, y1 * f), g, cv::COLOR_BGR2GRAY);
      if (f > 1) {
        cv::Mat s = small[k]->rowRange(y0, y1);
        cv::resize(g.colRange(0, s.cols * f), s, s.size(), 0, 0, cv::INTER_AREA);
      }
    }
  });
  cv::parallel_for_(cv::Range(0, 2 * kStripes), [&](const cv::Range& tasks) {
    for (int t = tasks.start; t < tasks.end; ++t) {
      const int k = t / kStripes, stripe = t % kStripes, rows = rectified[k]->rows;
      remapGreyRows(f > 1 ? *small[k] : *grey[k], *map[k][0], *map[k][1], rectified[k],
                    rows * stripe / kStripes, rows * (stripe + 1) / kStripes);
    }
  });
}

void DepthEstimator::buildSampleMap() {
  const Rectification& r = rectifier_.current();
  const int s = params_.cloud_stride_px;
  const cv::Size grid((r.size.width + s - 1) / s, (r.size.height + s - 1) / s);
  cv::Mat xy(grid, CV_16SC2), frac(grid, CV_16UC1);
  for (int gy = 0; gy < grid.height; ++gy) {
    for (int gx = 0; gx < grid.width; ++gx) {
      xy.at<cv::Vec2s>(gy, gx) = r.map_left[0].at<cv::Vec2s>(gy * s, gx * s);
      frac.at<uint16_t>(gy, gx) = r.map_left[1].at<uint16_t>(gy * s, gx * s);
    }
  }
  const int f = r.decimation;
  if (f == 1) {
    // The full map's own entries: the very colours a remap of the whole image gives.
    sample_map_[0] = xy;
    sample_map_[1] = frac;
  } else {
    // Pixel u of the decimated image is the block centred on (u + 0.5) f - 0.5 of the input;
    // back to fixed point, which remaps faster.
    cv::Mat input_xy;
    cv::convertMaps(xy, frac, input_xy, cv::noArray(), CV_32FC2);
    input_xy.convertTo(input_xy, CV_32FC2, f, 0.5 * f - 0.5);
    cv::convertMaps(input_xy, cv::noArray(), sample_map_[0], sample_map_[1], CV_16SC2);
  }
  sample_map_rebuilds_ = rectifier_.rebuilds();
}

bool DepthEstimator::process(const cv::Mat& left_bgr, const cv::Mat& right_bgr,
                             const PtzPose& left_pose, const PtzPose& right_pose,
                             const std::optional<Eigen::Vector3d>& target_head_m, DepthFrame* out,
                             std::string* why) {
  using Clock = std::chrono::steady_clock;
  const auto ms = [](Clock::duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
  };
  const StereoRig& rig = rectifier_.rig();
  for (Side side : {Side::kLeft, Side::kRight}) {
    const cv::Mat& image = side == Side::kLeft ? left_bgr : right_bgr;
    const CameraSpec& spec = rig.camera(side);
    if (image.type() != CV_8UC3 || image.cols != spec.width || image.rows != spec.height) {
      *why = std::string(sideName(side)) + " image is not BGR8 of the rig's " +
             std::to_string(spec.width) + "x" + std::to_string(spec.height);
      return false;
    }
  }
  const auto t0 = Clock::now();
  if (!rectifier_.update(left_pose, right_pose, why)) return false;
  const Rectification& r = rectifier_.current();
  if (sample_map_rebuilds_ != rectifier_.rebuilds()) buildSampleMap();
  rectifyPair(left_bgr, right_bgr);
  const auto t1 = Clock::now();

  const int num = params_.matcher.num_disparities;
  out->min_disparity_px = chooseMinDisparity(r, params_.horopter, num, target_head_m);
  matcher_.compute(left_rect_, right_rect_, out->min_disparity_px, &out->disparity_16s);
  const auto t2 = Clock::now();

  // Valid disparities inside the depth range, as (x, y, d) for one perspectiveTransform.
  const int d_lo = std::max<int>(out->min_disparity_px * 16,
                                 std::ceil(r.disparityAtDepth(params_.max_depth_m) * 16));
  const int d_hi = std::floor(r.disparityAtDepth(params_.min_depth_m) * 16);
  const int stride = params_.cloud_stride_px;
  xyd_.clear();
  out->colours_bgr.clear();
  const cv::Mat& disp = out->disparity_16s;
  const int grid_cols = sample_bgr_.cols;
  cell_.assign(static_cast<size_t>(grid_cols) * sample_bgr_.rows, -1);
  for (int y = 0, gy = 0; y < disp.rows; y += stride, ++gy) {
    const short* d = disp.ptr<short>(y);
    const cv::Vec3b* c = sample_bgr_.ptr<cv::Vec3b>(gy);
    for (int x = 0, gx = 0; x < disp.cols; x += stride, ++gx) {
      if (d[x] < d_lo || d[x] > d_hi) continue;
      cell_[static_cast<size_t>(gy) * grid_cols + gx] = static_cast<int>(xyd_.size());
      xyd_.emplace_back(static_cast<float>(x), static_cast<float>(y), d[x] / 16.0f);
      out->colours_bgr.push_back(c[gx]);
    }
  }
  // Q takes (x, y, d) to the rectified left camera; then rectified camera to head.
  Eigen::Matrix4d head_rect = Eigen::Matrix4d::Identity();
  head_rect.topLeftCorner<3, 3>() = r.rotation_head_rect;
  head_rect.topRightCorner<3, 1>() = r.position_head_m;
  cv::Mat H;
  cv::eigen2cv(head_rect, H);
  const cv::Mat M = H * r.Q;
  out->points_head_m.clear();
  if (!xyd_.empty()) cv::perspectiveTransform(xyd_, out->points_head_m, M);
  const auto t3 = Clock::now();
  out->outliers_dropped = 0;
  if (params_.outlier_stddev_mult > 0) {
    // Depth along the rectified axis: the grid's spacing on a surface facing the camera grows
    // with it.
    depths_.resize(xyd_.size());
    for (size_t i = 0; i < xyd_.size(); ++i) {
      depths_[i] = static_cast<float>(r.depthAtDisparity(xyd_[i].z));
    }
    out->outliers_dropped =
        removeGridOutliers(cell_, grid_cols, depths_, params_.outlier_stddev_mult,
                           &out->points_head_m, &out->colours_bgr, &outlier_scratch_);
  }
  const auto t4 = Clock::now();
  out->times = {ms(t1 - t0), ms(t2 - t1), ms(t3 - t2), ms(t4 - t3)};
  return true;
}

// Fewer points than this with neighbours: no statistics, all kept.
constexpr size_t kMinGridOutlierPoints = 10;

size_t removeGridOutliers(const std::vector<int>& cell, int cols, const std::vector<float>& depths,
                          double stddev_mult, std::vector<cv::Point3f>* points,
                          std::vector<cv::Vec3b>* colours, GridOutlierScratch* scratch) {
  const std::vector<cv::Point3f>& p = *points;
  CV_Assert(cols > 0 && cell.size() % static_cast<size_t>(cols) == 0);
  CV_Assert(depths.size() == p.size() && colours->size() == p.size());
  const int rows = static_cast<int>(cell.size()) / cols;
  // Per grid direction (horizontal, vertical, two diagonals) the distance to the nearer of the
  // two neighbours that way: an outlier on one side, or a surface's edge, leaves the other.
  constexpr float kNone = std::numeric_limits<float>::infinity();
  GridOutlierScratch local;
  GridOutlierScratch& buffers = scratch ? *scratch : local;
  std::vector<std::array<float, 4>>& nearer = buffers.nearer;
  nearer.assign(p.size(), {kNone, kNone, kNone, kNone});
  // Per grid step: a diagonal step is sqrt(2) steps long.
  const auto pair = [&p, &nearer](int i, int j, size_t k, float step_scale) {
    const cv::Point3f d = p[static_cast<size_t>(i)] - p[static_cast<size_t>(j)];
    const float len = std::sqrt(d.dot(d)) * step_scale;
    float& a = nearer[static_cast<size_t>(i)][k];
    float& b = nearer[static_cast<size_t>(j)][k];
    a = std::min(a, len);
    b = std::min(b, len);
  };
  constexpr float kDiagonal = 0.70710678f;
  for (int gy = 0; gy < rows; ++gy) {
    // Forward neighbours: right (direction 0), below (1), below right (2), below left (3).
    const int* row = cell.data() + static_cast<size_t>(gy) * cols;
    const int* below = gy + 1 < rows ? row + cols : nullptr;
    for (int gx = 0; gx < cols; ++gx) {
      const int i = row[gx];
      if (i < 0) continue;
      if (gx + 1 < cols && row[gx + 1] >= 0) pair(i, row[gx + 1], 0, 1.0f);
      if (!below) continue;
      if (below[gx] >= 0) pair(i, below[gx], 1, 1.0f);
      if (gx + 1 < cols && below[gx + 1] >= 0) pair(i, below[gx + 1], 2, kDiagonal);
      if (gx > 0 && below[gx - 1] >= 0) pair(i, below[gx - 1], 3, kDiagonal);
    }
  }
  // Each point's mean of those over its depth, as PCL's SOR takes its k nearest; none: isolated
  // (infinite: dropped).
  std::vector<double>& spread = buffers.spread;
  spread.resize(p.size());
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    double total = 0;
    int k = 0;
    for (float len : nearer[i]) {
      if (len == kNone) continue;
      total += len;
      ++k;
    }
    if (k == 0 || !(depths[i] > 0)) {
      spread[i] = std::numeric_limits<double>::infinity();
      continue;
    }
    spread[i] = total / k / depths[i];
    sum += spread[i];
    ++n;
  }
  if (n < kMinGridOutlierPoints) return 0;
  const double mean = sum / static_cast<double>(n);
  double var = 0;
  for (double s : spread) {
    if (std::isfinite(s)) var += (s - mean) * (s - mean);
  }
  var /= static_cast<double>(n);
  // (A frame of equal spreads, within rounding, drops none.)
  const double limit = mean + std::max(stddev_mult * std::sqrt(var), 1e-6 * mean);
  size_t kept = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    if (!(spread[i] <= limit)) continue;
    (*points)[kept] = (*points)[i];
    (*colours)[kept] = (*colours)[i];
    ++kept;
  }
  const size_t dropped = p.size() - kept;
  points->resize(kept);
  colours->resize(kept);
  return dropped;
}

cv::Mat disparityGrey(const DepthFrame& frame, int num_disparities) {
  cv::Mat grey;
  frame.disparity_16s.convertTo(grey, CV_8U, 255.0 / (16.0 * num_disparities),
                                -255.0 * frame.min_disparity_px / num_disparities);
  grey.setTo(0, frame.disparity_16s < frame.min_disparity_px * 16);
  return grey;
}

}  // namespace ptz::perception
