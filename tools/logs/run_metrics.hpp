// The numbers of a closed-loop run, from its messages: the demo's summary.json, the log
// summary and the closed-loop tests all compute them here, live or from a log.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::tools {

struct RunSummary {
  int64_t frames_published = 0;  // the simulator's (or camera's) count, else frames seen
  int64_t frames_processed = 0;  // OBJECT_POSE messages
  double latency_ms_p50 = NAN;   // frame capture -> setpoint publish (wall-clock runs only)
  double latency_ms_p99 = NAN;
  // STEREO_FRAME publish -> setpoint publish: the processing chain without the camera's (or
  // the simulator's render) delivery time.
  double chain_latency_ms_p50 = NAN;
  double chain_latency_ms_p99 = NAN;
  // ptz-control's live delay monitor (last report): capture -> setpoint plus the plant's dead
  // time, and the phase margin it leaves to the paper's loop model.
  double delay_ms_p99 = NAN;
  double phase_margin_deg = NAN;
  double centering_rms_px = NAN;  // true target to image centre, both cameras, after settle_s
  double centering_max_px = NAN;
  int64_t frames_target_outside_image = 0;  // after settle_s, either camera
  double position_error_rms_m = NAN;        // OBJECT_POSE target vs SIM_TRUTH
  double position_error_rms_pct_of_range = NAN;
  double target_lost_s = 0;  // frames without a target times the frame period
  int64_t poses_without_target = 0;
  int64_t frames_skipped_late = 0;  // by the simulator, running late (realtime)
  int64_t centering_samples = 0;
  int64_t position_samples = 0;

  std::string toJson() const;
};

class RunMetrics {
 public:
  explicit RunMetrics(std::string target_class = "red_ball", double settle_s = 2.0);

  void onFrame(const ptzstereo::stereo_frame_t& m);
  void onTruth(const ptzstereo::sim_truth_t& m);
  void onPose(const ptzstereo::object_pose_t& m);
  void onSetpoint(const ptzstereo::ptz_setpoint_t& m);
  void onStatus(const ptzstereo::process_status_t& m);

  RunSummary summary() const;
  // Pixel offsets (left x, left y, right x, right y) of the true target from the image centres,
  // by frame sequence number, after settle_s.
  const std::map<int64_t, std::vector<double>>& centeringByFrame() const { return centering_; }

 private:
  std::string target_class_;
  double settle_s_;
  int64_t first_utime_ = -1;
  int64_t frames_seen_ = 0;
  int64_t frame_period_us_ = 0;
  int64_t last_frame_utime_ = -1;
  int64_t last_truth_utime_ = -1;
  std::map<int64_t, std::vector<double>> truth_position_;  // seq -> x, y, z
  std::map<int64_t, std::vector<double>> centering_;
  std::vector<double> position_error_m_, position_error_pct_;
  std::vector<double> latency_ms_, chain_latency_ms_;
  std::map<int64_t, int64_t> frame_publish_utime_;  // seq -> publish_utime
  int64_t poses_ = 0, poses_without_target_ = 0;
  std::map<std::string, int64_t> counters_;  // "process.counter" of the last status
  int64_t outside_ = 0;
};

}  // namespace ptz::tools
