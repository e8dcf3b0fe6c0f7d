// What ptz-calibrate does around the calibration, without LCM: its parameters, the progress on
// stderr and the report on stdout, the file source's three modes (stereo, zoom, pivot), and the
// live source's handling of a decoded frame (at home? a view kept? saved, printed).
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "perception/calibrate/calibration.hpp"
#include "perception/calibrate/calibration_live.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::perception {

// Everything but the transport's parameters (the live source's), in the order of --help.
void declareCalibrateParams(Params& p);
BoardSpec boardOf(const Params& p);
// The output folders can be written: checked before the long part, not after it.
void checkOutputs(const Params& p);
// Calibrates, prints the report and writes the output files (rig file, camera_info).
void calibrateAndWrite(const Params& p, const std::vector<ViewPair>& views, cv::Size size);
// The file source (images_dir or image_list) in --mode stereo, zoom or pivot; 0, or throws
// (ConfigError naming the parameter or file).
int runFiles(const Params& p);

// The live source's views: frames at home (pan = tilt = 0, --zoom) are offered to the
// collector; kept views are saved (save_views_dir) and printed.
class LiveViews {
 public:
  explicit LiveViews(const Params& p);
  // "" when both cameras of m are at home at --zoom; else why not (the frame is not used).
  std::string notAtHome(const ptzstereo::stereo_frame_t& m) const;
  // Offers the decoded images of frame seq; a kept view is saved and printed.
  LiveCollector::Result offer(const cv::Mat& left, const cv::Mat& right, int64_t seq);
  // Enough views kept (target_views).
  bool done() const { return collector_.views().size() >= target_; }
  size_t target() const { return target_; }
  const LiveCollector& collector() const { return collector_; }

 private:
  LiveCollector collector_;
  size_t target_;
  std::string save_dir_;
  double zoom_, home_tolerance_rad_;
};

}  // namespace ptz::perception
