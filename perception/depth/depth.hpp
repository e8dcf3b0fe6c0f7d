// Dense depth from a PTZ stereo pair (paper, section 2.4): rectification with the frame's own
// geometry, block matching (OpenCV StereoBM, or StereoSGBM as a quality mode) over a horopter
// that can follow the target, and reprojection of the sampled valid disparities into the head
// frame. Large frames are matched decimated. No PCL here (cloud.hpp holds it) and no LCM.
#pragma once

#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.hpp"

namespace cv::ximgproc {
class DisparityWLSFilter;
}
namespace ptz {
class Params;
}

namespace ptz::perception {

struct MatcherParams {
  enum class Mode { kBm, kSgbm };
  Mode mode = Mode::kBm;
  int num_disparities = 64;  // width of the search range (the horopter), a multiple of 16
  int block_size_px = 11;    // SAD window of BM (odd, 5..255)
  int sgbm_block_size_px = 3;
  int prefilter_size_px = 7;  // paper: normalised over 7x7
  int prefilter_cap = 31;
  int texture_threshold = 10;  // BM: least sum of |gradient| in the window
  int uniqueness_pct = 15;     // best cost this % below the second best
  int speckle_window_px = 100;
  int speckle_range_px = 2;
  int lr_max_diff_px = 1;  // left-right consistency; < 0: off
  // Pads the images so that the search range fits at the left edge too: pixels there are
  // matched instead of left invalid (costs num_disparities more columns).
  bool full_width = false;
  bool wls = false;  // ximgproc's WLS filter on the disparity (quality mode)
  double wls_lambda = 8000;
  double wls_sigma = 1.5;

  static Mode parseMode(const std::string& name);
  static const char* modeName(Mode mode);
};

// Disparity of a rectified pair, CV_16S in 1/16 px; invalid pixels < min_disparity * 16.
class DisparityMatcher {
 public:
  explicit DisparityMatcher(MatcherParams params);
  // Grey 8-bit rectified images of the same size.
  void compute(const cv::Mat& left_gray, const cv::Mat& right_gray, int min_disparity_px,
               cv::Mat* disparity_16s);
  const MatcherParams& params() const { return params_; }

 private:
  void match(const cv::Mat& left_gray, const cv::Mat& right_gray, int min_disparity_px,
             cv::Mat* disparity_16s);

  MatcherParams params_;
  cv::Ptr<cv::StereoMatcher> matcher_;
  cv::Ptr<cv::StereoMatcher> right_matcher_;  // WLS only
  cv::Ptr<cv::ximgproc::DisparityWLSFilter> wls_;
  cv::Mat left_pad_, right_pad_, disp_pad_;  // scratch of full_width
};

// The smallest integer factor that brings width_px to at most max_width_px (<= 0: 1).
int decimationFor(int width_px, int max_width_px);
// The rig's cameras read out decimated by an integer factor, as f x f blocks averaged
// (cv::INTER_AREA) of the image cropped to a multiple of f: focal lengths / f, pixel centres
// (x + 0.5) / f - 0.5, size / f rounded down.
StereoRig decimatedRig(const StereoRig& rig, int factor);

// Rectification of one stereo geometry (both views and their relative pose), at the matched size.
struct Rectification {
  // initUndistortRectifyMap, fixed point: rectified pixel of the matched size to a pixel of the
  // input decimated by `decimation`.
  cv::Mat map_left[2], map_right[2];
  cv::Mat R1, R2, P1, P2, Q;  // cv::stereoRectify, of the matched size
  cv::Size size;              // the matched size
  int decimation = 1;
  // Rectified-left camera frame to head frame.
  Eigen::Matrix3d rotation_head_rect = Eigen::Matrix3d::Identity();
  Eigen::Vector3d position_head_m = Eigen::Vector3d::Zero();

  // Disparity (px) of a head-frame point, NaN behind the cameras.
  double disparityOf(const Eigen::Vector3d& p_head) const;
  // Disparity (px) of a point at depth_m straight ahead of the rectified left camera.
  double disparityAtDepth(double depth_m) const;
  // Its inverse: the depth (m) along the rectified axis of a disparity (px).
  double depthAtDisparity(double disparity_px) const;
};

// Builds rectification maps for the pose of a frame; rebuilds only when the pose changes.
// decimation > 1: the maps and P, Q are those of the rig decimated by it (decimatedRig).
class Rectifier {
 public:
  explicit Rectifier(StereoRig rig, int decimation = 1);
  // False (with the reason) when the geometry is unknown: zoom outside the calibrated table or
  // non-finite angles.
  bool update(const PtzPose& left, const PtzPose& right, std::string* why);
  const Rectification& current() const { return rect_; }
  int rebuilds() const { return rebuilds_; }
  const StereoRig& rig() const { return rig_; }  // at the input size
  int decimation() const { return decimation_; }

 private:
  StereoRig rig_, matched_rig_;
  int decimation_;
  Rectification rect_;
  std::optional<std::pair<PtzPose, PtzPose>> pose_;
  int rebuilds_ = 0;
};

// Where the disparity search lies, in the order it is chosen: around the target's disparity,
// else ending at the disparity of far_depth_m, else from min_disparity_px.
struct HoropterParams {
  bool follow_target = true;
  double far_depth_m = 10.0;  // <= 0: use min_disparity_px (parameter horopter_far_m)
  int min_disparity_px = 0;
};
int chooseMinDisparity(const Rectification& rect, const HoropterParams& params, int num_disparities,
                       const std::optional<Eigen::Vector3d>& target_head_m);

struct DepthParams {
  MatcherParams matcher;
  HoropterParams horopter;
  double min_depth_m = 0.3;   // points nearer or farther are dropped
  double max_depth_m = 20.0;  // (depth along the rectified left axis)
  int cloud_stride_px = 4;    // reproject every n-th pixel of the matched pair in x and y
  // Wider pairs are matched decimated by the smallest integer factor that brings them to at most
  // this width (0: never): 1080p at 960 x 540.
  int match_max_width_px = 1000;
  // Statistical outlier removal on the sampling grid: a point whose spread (the mean, over the
  // grid's four directions, of the distance to the nearer neighbour that way, relative to its
  // range) is this many standard deviations above the frame's mean is dropped, as is a point
  // without neighbours (0: off).
  double outlier_stddev_mult = 1.0;

  // Reads the parameters declared by declareDepthParams (errors name the parameter).
  static DepthParams fromParams(const Params& params);
};
// Declares the parameters of DepthParams with their defaults, units and help.
void declareDepthParams(Params& params);

// Buffers of removeGridOutliers, kept between frames.
struct GridOutlierScratch {
  std::vector<std::array<float, 4>> nearer;
  std::vector<double> spread;
};
// Drops the grid outliers of outlier_stddev_mult (above) from points and colours. cell: for each
// node of a grid of `cols` columns (row-major), the index of its point or -1; depths: each
// point's depth along the camera's axis; scratch: optional. Returns how many it dropped.
size_t removeGridOutliers(const std::vector<int>& cell, int cols, const std::vector<float>& depths,
                          double stddev_mult, std::vector<cv::Point3f>* points,
                          std::vector<cv::Vec3b>* colours, GridOutlierScratch* scratch = nullptr);

// Wall-clock time of each step of DepthEstimator::process.
struct DepthStepTimes {
  double rectify_ms = 0;    // grey, decimation, remap; the samples' colours
  double match_ms = 0;      // DisparityMatcher::compute
  double reproject_ms = 0;  // sampling, reprojection
  double outliers_ms = 0;   // removeGridOutliers
};

// Valid disparities of one frame as head-frame points with the left image's colour.
struct DepthFrame {
  std::vector<cv::Point3f> points_head_m;
  std::vector<cv::Vec3b> colours_bgr;
  size_t outliers_dropped = 0;  // by the grid outlier filter
  cv::Mat disparity_16s;        // rectified left view, at the matched size
  int min_disparity_px = 0;     // in pixels of the matched size
  DepthStepTimes times;
};

// The disparity of a frame as grey levels over the search range (DISPARITY_IMAGE), 0 where
// there is none.
cv::Mat disparityGrey(const DepthFrame& frame, int num_disparities);

// Rectify + match + reproject for frames of a rig; keeps its maps and matcher between frames.
class DepthEstimator {
 public:
  DepthEstimator(StereoRig rig, DepthParams params);
  // BGR8 images of the rig's size, each with its PTZ pose at capture. False (why set) when the
  // geometry of the frame is unknown or the images are not of the rig's size. Reusing `out`
  // reuses its buffers.
  bool process(const cv::Mat& left_bgr, const cv::Mat& right_bgr, const PtzPose& left_pose,
               const PtzPose& right_pose, const std::optional<Eigen::Vector3d>& target_head_m,
               DepthFrame* out, std::string* why);
  const Rectifier& rectifier() const { return rectifier_; }
  const DepthParams& params() const { return params_; }
  int decimation() const { return rectifier_.decimation(); }
  // The grey rectified pair of the last frame, as matched.
  const cv::Mat& matchedLeft() const { return left_rect_; }
  const cv::Mat& matchedRight() const { return right_rect_; }

 private:
  // Both images to grey, decimated and rectified; the samples' colours.
  void rectifyPair(const cv::Mat& left_bgr, const cv::Mat& right_bgr);
  void buildSampleMap();

  DepthParams params_;
  Rectifier rectifier_;
  DisparityMatcher matcher_;
  // Scratch, kept between frames: no allocation once the sizes settle.
  cv::Mat left_grey_, right_grey_, left_small_, right_small_, left_rect_, right_rect_;
  // The left rectification map at the samples only, into the input image: their colours
  // without a rectified colour image (rebuilt with the rectification).
  cv::Mat sample_map_[2], sample_bgr_;
  int sample_map_rebuilds_ = -1;
  std::vector<int> cell_;  // sampling grid -> point index
  std::vector<cv::Point3f> xyd_;
  std::vector<float> depths_;
  GridOutlierScratch outlier_scratch_;
};

}  // namespace ptz::perception
