// Stereo calibration from chessboard views (no LCM): corner detection, mono and stereo
// calibration with OpenCV (Zhang's method, 5-coefficient Brown distortion), rectification, per-view
// errors, outlier views and degenerate sets, and the rig file with the calibration's extra fields.
#pragma once

#include <opencv2/core.hpp>

#include <functional>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "common/rig.hpp"

namespace ptz::perception {

// Bad calibration input (files, board, views). what() names the files; exit code 2 like every
// other bad input file.
class CalibrationError : public ConfigError {
 public:
  using ConfigError::ConfigError;
};

// Progress of long work, one line at a time: `stage` lines (a new step) matter, the others
// (one per image) may be thinned out by the caller.
using Progress = std::function<void(const std::string& line, bool stage)>;

struct BoardSpec {
  int inner_cols = 9;  // inner corners along a row (not squares)
  int inner_rows = 6;
  double square_m = 0.025;

  cv::Size size() const { return {inner_cols, inner_rows}; }
  std::string text() const;  // "9x6 inner corners, 0.025 m squares"
};

// Board-frame corners (z = 0), row by row, in metres: findChessboardCorners' order.
std::vector<cv::Point3f> boardPoints(const BoardSpec& board);

// Inner corners of the board in an 8-bit image, refined to sub-pixel; false when not found.
bool findCorners(const cv::Mat& image, const BoardSpec& board,
                 std::vector<cv::Point2f>* corners_px);

// Corners of one stereo view; the names are what messages report (file names, frame numbers).
struct ViewPair {
  std::string left_name, right_name;
  std::vector<cv::Point2f> left_px, right_px;
};

// Reverses `right` when OpenCV reported the board from the other end than in `left` (a board with
// an odd and an even count is found from either end), so that both index the same corners.
void alignCornerOrder(const std::vector<cv::Point2f>& left, std::vector<cv::Point2f>* right);

struct MonoCalibration {
  cv::Mat K, D;  // 3x3 camera matrix; 1x5 k1 k2 p1 p2 k3
  double rms_px = 0;
  std::vector<double> view_rms_px;
  std::vector<cv::Mat> rvecs, tvecs;  // board pose in the camera per view
  std::vector<double> tilt_deg;       // angle between board normal and optical axis per view

  Intrinsics intrinsics() const;
};

// cv::calibrateCamera with per-view errors and board tilts; `flags` are cv::CALIB_* (K and D
// are the initial guess with CALIB_USE_INTRINSIC_GUESS). Throws CalibrationError naming `what`.
MonoCalibration calibrateMono(const std::vector<std::vector<cv::Point3f>>& object_points,
                              const std::vector<std::vector<cv::Point2f>>& image_points,
                              cv::Size image_size, int flags, const std::string& what,
                              const cv::Mat& K_guess = {}, const cv::Mat& D_guess = {});

struct StereoOptions {
  int min_views = 8;
  double max_view_error_px = 1.0;  // per-view RMS above this: an outlier
  bool drop_outliers = false;      // recalibrate without the outliers (else only report them)
  double min_tilt_deg = 10;        // some view must tilt the board at least this much
  double rectify_alpha = 0;        // cv::stereoRectify's alpha: 0 valid pixels only, 1 all
  // Refine both cameras' intrinsics with R, T in cv::stereoCalibrate (from the mono results);
  // false: keep the mono intrinsics fixed.
  bool refine_intrinsics = true;
  Progress progress;  // stage lines; empty: none
};

struct ViewReport {
  std::string left_name, right_name;
  double left_rms_px = 0, right_rms_px = 0;  // stereo fit, per camera
  double left_tilt_deg = 0;
};

struct DroppedView {
  std::string name;
  std::string reason;
};

struct StereoCalibration {
  BoardSpec board;
  cv::Size image_size;
  MonoCalibration left, right;  // K, D after the stereo fit; rms_px, view_rms_px of the mono fit
  cv::Mat R, T, E, F;           // x_right = R x_left + T, T in metres
  cv::Mat R1, R2, P1, P2, Q;    // cv::stereoRectify at home
  double stereo_rms_px = 0;
  double rectified_epipolar_px = 0;   // mean |y_left - y_right| of the corners after rectification
  std::vector<ViewReport> views;      // the views used
  std::vector<DroppedView> dropped;   // outliers dropped, with the reason
  std::vector<std::string> outliers;  // views above max_view_error_px (dropped or not)
  std::string date_utc;

  // The rig model: one zoom table entry at `zoom`, optical centre on the pivot (unknown here).
  StereoRig toRig(double zoom = 1) const;
};

// Mono calibration of each camera, then cv::stereoCalibrate (from the mono intrinsics, refined
// with R, T unless options.refine_intrinsics is false; in the simulator that cuts the errors of
// f, T and R 2-8 times), then cv::stereoRectify. `left`/`right` hold the final intrinsics and the
// mono RMS. Throws CalibrationError for too few views or a degenerate set.
StereoCalibration calibrateStereo(const std::vector<ViewPair>& views, const BoardSpec& board,
                                  cv::Size image_size, const StereoOptions& options);

// "2026-11-22T06:30:00Z": the date fields of the reports.
std::string utcNow();

// The rig file (StereoRig::save, so every process loads it) plus the calibration's fields:
// E, F, R1, R2, P1, P2, Q, mono and stereo RMS, per-view errors, epipolar error, board, date.
void saveCalibration(const std::string& path, const StereoRig& rig, const StereoCalibration& c);
// Copies the fields of a rig file (its root, read before the file is overwritten) that are not
// the rig's own (a calibration's report) into fs, except those named in `skip`: a rig file
// updated by a later step keeps them.
void copyReportFields(const cv::FileNode& rig_root, cv::FileStorage& fs,
                      const std::vector<std::string>& skip);
// Writes a node read with FileStorage back (name empty inside a list), matrices as matrices.
void copyFileNode(cv::FileStorage& fs, const std::string& name, const cv::FileNode& node);
// ROS camera_info YAML (plumb_bob) of one camera, rectification and projection included.
void saveCameraInfo(const std::string& path, const StereoCalibration& c, Side side);
// camera_info of both cameras at every zoom of the rig's tables (cv::stereoRectify at home with
// that zoom's intrinsics): left.yaml/right.yaml at zoom 1, left_zoomZ.yaml/right_zoomZ.yaml
// (Z as %g: left_zoom2.5.yaml) at the others. Returns the files written.
std::vector<std::string> saveCameraInfos(const std::string& dir, const StereoRig& rig,
                                         double rectify_alpha);
// Creates `dir` (and its parents) if missing and checks a file can be written in it: before
// long work whose results go there. ConfigError naming the folder and the reason.
void requireWritableDir(const std::string& dir, const std::string& what);

}  // namespace ptz::perception
