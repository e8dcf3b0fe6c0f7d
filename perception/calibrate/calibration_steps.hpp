// The steps after the home calibration, on a rig file: each reads the rig file, adds what it
// measured and writes it (possibly over itself) with the earlier steps' report fields kept.
#pragma once

#include <string>
#include <vector>

#include "perception/calibrate/calibration_files.hpp"
#include "perception/calibrate/ptz_calibration.hpp"

namespace ptz::perception {

// The rig file to extend; CalibrationError when it is for another image size than the views'.
StereoRig loadRigFor(const std::string& rig_path, cv::Size image_size);

struct ZoomStep {
  MonoCalibration left, right;
};
// Each camera's intrinsics at `zoom` from its own images (the board need not be in both) into the
// zoom tables; the report gains an entry in `zoom_calibrations`.
ZoomStep addZoomEntry(const std::string& rig_path, const std::string& output_path, double zoom,
                      const DetectedViews& views, const BoardSpec& board, int min_views);

struct PivotStep {
  PivotEstimate left, right;
  int left_views = 0, right_views = 0;
};
// Each camera's optical centre relative to its pivot from views of a board that stays put while
// the cameras pan and tilt (one DetectedViews per board station; angles used when given), with
// the intrinsics at `zoom`; the report gains `pivot_calibration`.
PivotStep setPivotOffsets(const std::string& rig_path, const std::string& output_path, double zoom,
                          const std::vector<DetectedViews>& stations, const BoardSpec& board);

}  // namespace ptz::perception
