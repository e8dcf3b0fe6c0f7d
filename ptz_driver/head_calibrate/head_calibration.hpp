// Measures a PTZ head's angle map from image motion: the pan and tilt units per radian from the
// shift of the scene between small moves about home, and the zoom ratio of zoom units from the
// scene's scale between neighbouring zoom positions (chained from the widest, which is the rig's
// smallest zoom). The rig (ptz-calibrate's) is the ruler; the scene must be static and textured.
// No LCM and no head: it is given frames and says where the heads are to be.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "ptz_driver/head_calibrate/view_fit.hpp"

namespace ptz::driver {

// A head's position in its own units (ONVIF's normalised spaces, VISCA's counts).
struct UnitPose {
  double pan = 0, tilt = 0, zoom = 0;
};

// What the model file at hand says, used only to start: where home is and how big a move is.
struct UnitMapGuess {
  UnitPose home;  // pan = tilt = 0 at the widest zoom (zoom at its minimum)
  double pan_units_per_rad = 1, tilt_units_per_rad = 1;
  double zoom_max_units = 1;
  std::function<double(double)> zoom_ratio;  // zoom units -> ratio
  double unit_step = 0;                      // the units' resolution (1: integers); 0: none
};

struct HeadCalibrationSettings {
  double move_rad = 0.05;        // pan and tilt moves: ±1 and ±2 of these about home
  double zoom_step_ratio = 1.1;  // consecutive zoom positions at most this far apart
  int zoom_positions_min = 16;   // the zoom range in at least this many steps
  // Then positions are added where the table, interpolated linearly, may miss the lens by more
  // than this part of the zoom ratio (judged from the neighbouring steps' slopes).
  double zoom_table_tolerance = 0.005;
  double settle_s = 0.4;  // the image still (within settle_px) over this long
  double settle_px = 0.2;
  double arrive_fraction = 0.01;  // and the head within this part of its move of the target
  double move_timeout_s = 20;
  int max_corners = 500;
};

struct UnitMap {
  // [left, right]
  std::array<double, 2> pan_units_per_rad{}, tilt_units_per_rad{};
  std::array<double, 2> pan_rms_rad{}, tilt_rms_rad{};  // of the moves about the fitted line
  std::vector<double> zoom_units;
  std::array<std::vector<double>, 2> zoom_ratios;
};

class HeadCalibration {
 public:
  enum class State { kRunning, kDone, kFailed };

  HeadCalibration(StereoRig rig, UnitMapGuess guess, HeadCalibrationSettings settings);
  // Where both heads are to be now.
  const UnitPose& target() const { return target_; }
  // A stereo frame (grey) received at now_s, with where the heads say they are (nullopt: they
  // do not know yet).
  State onFrame(const cv::Mat& left, const cv::Mat& right, double now_s,
                const std::array<std::optional<UnitPose>, 2>& measured);
  State state() const { return state_; }
  const std::string& error() const { return error_; }
  const UnitMap& result() const { return map_; }
  // What happened since the last call, a line per measurement.
  std::vector<std::string> takeLog();

 private:
  enum class Phase { kHome, kPan, kTilt, kZoom };
  void moveTo(const UnitPose& target, double now_s);
  bool arrived(const std::array<std::optional<UnitPose>, 2>& measured) const;
  bool settled(const cv::Mat& left, const cv::Mat& right, double now_s);
  void measure(const cv::Mat& left, const cv::Mat& right, double now_s);
  void measureTurn(const cv::Mat& left, const cv::Mat& right, double now_s);
  void measureZoom(const cv::Mat& left, const cv::Mat& right, double now_s);
  void nextZoom(double now_s);
  void refineZoom(double now_s);
  double interpolationError(size_t interval) const;
  void fail(const std::string& why);
  void log(const std::string& line) { log_.push_back(line); }

  StereoRig rig_;
  UnitMapGuess guess_;
  HeadCalibrationSettings settings_;
  State state_ = State::kRunning;
  std::string error_;
  UnitMap map_;
  std::vector<std::string> log_;

  Phase phase_ = Phase::kHome;
  UnitPose target_, previous_target_;
  double moved_at_s_ = 0;
  // Settling: the first frame of the still window.
  std::array<cv::Mat, 2> window_;
  std::array<std::vector<cv::Point2f>, 2> window_corners_;
  double window_start_s_ = -1;

  // Home: what each camera saw and the scene's points.
  std::array<cv::Mat, 2> home_;
  std::array<ScenePoints, 2> scene_;
  size_t move_ = 0;        // index into kMoves of the axis at hand
  double step_units_ = 0;  // of the axis at hand, per kMoves unit
  std::array<std::vector<std::pair<double, double>>, 2> moves_;  // (units from home, rad)
  // Zoom: every position's images (as map_.zoom_units), the one the target is measured from, what
  // the target's ratio is expected to be.
  std::vector<std::array<cv::Mat, 2>> zoom_images_;
  size_t zoom_from_ = 0;
  std::array<double, 2> zoom_guess_{};
  double zoom_slope_ = 0;  // ratio per unit, of the last step
  bool refining_ = false;  // the sweep reached the top: positions are being added between
};

}  // namespace ptz::driver
