// The numbers of a closed-loop run, from its messages: the demo's summary.json, the log
// summary and the closed-loop tests all compute them here, live or from a log.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "ptzstereo/camera_model_t.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::tools {

// A camera of SIM_TRUTH as the rig's view (its pose and intrinsics at capture).
CameraView toView(const ptzstereo::camera_model_t& m);

struct RunSummary {
  int64_t frames_published = 0;  // the simulator's count, else frames seen (by any message)
  // Made by the simulator but refused by LCM (no route: a link down), its publish_failures.
  int64_t frames_not_published = 0;
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
  // The tracked true object to the image centre, both cameras, from settle_s after the first lock
  // (the first pose with a target; NaN: never locked); frames where it is behind either camera
  // are left out (and counted outside the image). In VGA-equivalent px (scaled by 640 / width),
  // so runs at every resolution compare.
  double centering_rms_px = NAN;
  double centering_max_px = NAN;
  int64_t frames_target_outside_image = 0;  // as centring is counted, either camera (or behind)
  double position_error_rms_m = NAN;        // OBJECT_POSE target vs the tracked true object
  double position_error_rms_pct_of_range = NAN;
  double position_error_max_pct_of_range = NAN;  // the worst single pose
  // The same over the poses counted for centring (from settle_s after the first lock): the heads
  // turned and zoomed to what they found.
  double position_error_settled_rms_pct_of_range = NAN;
  // Frames without a pose or whose pose has no target, times the frame period (NaN when some
  // are lost but the period is unknown).
  double target_lost_s = 0;
  int64_t poses_without_target = 0;
  int64_t frames_without_pose = 0;  // frames of the run ptz-detect never answered
  double time_to_acquire_s = NAN;   // first frame -> first pose with a target (NaN: never)
  // Frames ptz-control spent searching, and coasting, times the frame period (CONTROL_STATE;
  // NaN when there is none).
  double search_time_s = NAN;
  double coast_time_s = NAN;
  // Frames with a target whose tracked true object is not that of the previous such frame.
  int64_t target_switches = 0;
  // The tracked true object fully visible again (SIM_TRUTH: at least 98 % of its pixels not
  // hidden, the whole disk of its radius inside both images) after it was not, since its first
  // acquisition: how often, and the longest time from then to the first pose with it as the target
  // (where that never came, the time it stayed fully visible; NaN: it was never hidden).
  int64_t reappearances = 0;
  double reacquire_max_s = NAN;
  int64_t frames_skipped_late = 0;  // by the simulator, running late (realtime)
  int64_t centering_samples = 0;
  int64_t position_samples = 0;
  // OBJECT_POSE target's orientation vs the tracked true object's (SIM_TRUTH), a box's taken
  // modulo its symmetry (turns by 90 degrees about its vertical axis: a square footprint; a tagged
  // box's none): the angle of the rotation between them, over the poses that have one and a box as
  // the truth.
  double orientation_error_rms_deg = NAN;
  int64_t orientation_samples = 0;

  std::string toJson() const;
};

// One frame of the run as scored.
struct FrameScore {
  int64_t utime = 0;  // capture time
  bool pose = false;  // OBJECT_POSE answered it
  bool target = false;
  // The true object the pose's target was matched to ("" when none), and where it was.
  std::string tracked;
  std::array<double, 3> tracked_truth_m{NAN, NAN, NAN};
  int control_state = -1;  // CONTROL_STATE's state (-1: none)
};

class RunMetrics {
 public:
  explicit RunMetrics(std::string target_class = "red_ball", double settle_s = 2.0);

  void onFrame(const ptzstereo::stereo_frame_t& m);
  void onTruth(const ptzstereo::sim_truth_t& m);
  void onPose(const ptzstereo::object_pose_t& m);
  void onSetpoint(const ptzstereo::ptz_setpoint_t& m);
  void onControlState(const ptzstereo::control_state_t& m);
  void onStatus(const ptzstereo::process_status_t& m);

  // Everything received so far, scored in frame order: a pose that came before its truth is
  // scored once the truth is there, and the numbers do not depend on the arrival order.
  RunSummary summary() const;
  // Pixel offsets (left x, left y, right x, right y) of the tracked true object from the image
  // centres, by frame sequence number, from settle_s after the first lock, where it is in front of
  // both cameras.
  std::map<int64_t, std::vector<double>> centeringByFrame() const;
  // Every frame seen (by any message), by sequence number.
  std::map<int64_t, FrameScore> frames() const;

 private:
  struct TruthObject {
    int name = -1, class_name = -1;  // into names_
    std::array<double, 3> position_m{};
    bool in_front = false;       // of both cameras
    bool inside = false;         // of both images
    bool fully_visible = false;  // none of it hidden, all of it inside both images
    std::array<double, 4> offset_px{};
    // Quarter turns about y its orientation is taken up to: 4 a box, 1 a tagged box (its tags
    // tell every face apart), 0 none (a sphere).
    int orientation_symmetry = 0;
    std::array<double, 4> orientation_wxyz{1, 0, 0, 0};
  };
  struct Pose {
    int64_t utime = 0;
    bool target = false;
    bool finite = false;  // the target's estimate is a number
    int class_name = -1;
    std::array<double, 3> estimate_m{};
    bool has_orientation = false;
    std::array<double, 4> orientation_wxyz{1, 0, 0, 0};
  };
  struct Scored;
  Scored score() const;
  int intern(const std::string& s);
  void noteFrame(int64_t seq, int64_t utime);

  std::string target_class_;
  double settle_s_;
  std::vector<std::string> names_;  // object names and classes, interned
  std::map<std::string, int> name_index_;
  int64_t frames_seen_ = 0, poses_ = 0, poses_without_target_ = 0, control_states_ = 0;
  std::map<int64_t, int64_t> frame_utime_;          // seq -> capture time, from any message
  std::map<int64_t, int64_t> frame_publish_utime_;  // seq -> STEREO_FRAME publish_utime
  std::map<int64_t, std::vector<TruthObject>> truth_;
  std::map<int64_t, Pose> pose_;
  std::map<int64_t, int> control_state_;
  std::vector<std::pair<int64_t, int64_t>> setpoint_publish_;  // seq, publish_utime
  std::vector<double> latency_ms_;
  std::map<std::string, int64_t> counters_;  // "process.counter" of the last status
};

}  // namespace ptz::tools
