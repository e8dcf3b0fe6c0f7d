// ptz-detect's work on a frame (no LCM): the images decoded as far as they are scanned (windows
// around the tracks' predicted images, a band or the whole image), both images' regions, their
// stereo pairs triangulated, the boxes' yaws, the tracker's update and the target's choice, as the
// three messages ptz-detect publishes; and TARGET_SELECT requests. Tagged objects (fiducial
// markers, marker_scan.hpp) join the colour objects: their detections, objects and tracks follow
// the colour ones' in each message, then faces and people (people_scan.hpp), then a clicked
// object. The main checks what comes in
// (FrameIntake, FreshnessGate), publishes what comes out and copies counters() into its status.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/rig.hpp"
#include "perception/appearance/clicked.hpp"
#include "perception/detect/detect_params.hpp"
#include "perception/detect/new_objects.hpp"
#include "perception/tracking/target.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"

namespace ptz::perception {

class FramePixels;

// One frame's messages, each carrying the frame's utime and seq (publish_utime left 0).
struct FrameOutputs {
  ptzstereo::object_detections_t detections;
  // target_index: the object that updated the locked track in this frame (-1: none).
  ptzstereo::object_pose_t pose;
  ptzstereo::object_tracks_t tracks;
  // The target's reason changed in this frame (ptz-detect says the new one on stderr).
  bool target_reason_changed = false;
  // A click's model started or refused, or its object lost, in this frame (said on stderr).
  std::string click_note;
  // The search for new objects of an earlier frame failed (discover(); said on stderr).
  std::string new_objects_note;
};

class DetectPipeline {
 public:
  // rig: the frames' rig (its image size is theirs).
  DetectPipeline(DetectConfig config, StereoRig rig);
  ~DetectPipeline();

  // One frame, accepted already (checkStereoFrame; checkFrameMatchesRig: the rig's size, in
  // colour): its messages in *out. False and *why when an image does not decode (the frame is
  // dropped; the tracks and the target are as before it).
  bool process(const ptzstereo::stereo_frame_t& frame, FrameOutputs* out, std::string* why);
  // The search for new tags, faces and people in the frame process() took last (a band and a
  // strip of it), once its messages are out: the latency of the frame's pose is its tracked
  // objects' alone. What it finds joins the tracker at the frame's time (Tracker::updateLate): new
  // objects start tracks, which the next frame's windows confirm and its messages carry. With
  // new_objects_background it runs on a thread of its own (NewObjectSearch) and joins the tracker
  // when a later frame is processed (not searched while it runs: counted). The frame waits for it
  // while there is no target (no pose to delay; finding one is what matters) and when repeatable
  // (a run to be repeated bit for bit; ptz-detect asks it of frames whose capture times are not
  // the wall clock's). False and *why when a part does not decode (counted; in the background:
  // said by the next frame's FrameOutputs::new_objects_note).
  bool discover(const ptzstereo::stereo_frame_t& frame, bool repeatable, std::string* why);
  // Why the search's thread could not be made nicer ("" when it was, or there is none).
  std::string newObjectsThreadProblem() const;

  // A TARGET_SELECT request (fresh: the main judged it) against the tracks and the views of the
  // newest frame processed. False and *why when it cannot be met: an unknown class, track or
  // mode, a camera neither left nor right, a point outside the image or before any frame; the
  // target then stays. A point on no track (with click_to_track) starts a model of what is under
  // it with the next frame, and the target becomes that object (class "clicked").
  bool select(const ptzstereo::target_select_t& request, std::string* why);

  int64_t targetId() const { return selector_.targetId(); }
  const std::string& targetReason() const { return selector_.reason(); }
  const Tracker& tracker() const { return tracker_; }

  // The counters of PROCESS_STATUS_PTZ_DETECT, by name, as of the newest frame processed (totals
  // since the start and the latest values): frames_processed, frames_without_target, target_id,
  // target_changes, tracks_live, tracks_started, tracks_recovered, tracks_refused,
  // track_yaws_accepted, track_yaws_refused, untrusted_<reason>, the windows' (WindowScanner::
  // counts), orientations_estimated, _failed, _skipped, orientation_views_decoded, and every 30
  // frames (boxes) processing_us_p50/_p99 (orientation_us_p50/_p99); discover()'s late_known,
  // late_updates, late_starts, late_dropped, discoveries_failed, new_object_searches_skipped,
  // new_objects_too_late, NewObjectSearch::counts() (summed with the windows' scanners') and
  // every 30 discovery_us_p50/_p99; the target's colour class's color_<class>_hue_offset_cdeg,
  // color_<class>_gate_halfwidth_cdeg and appearance_out_of_range_frames.
  const std::map<std::string, int64_t>& counters() const { return counters_; }
  // Where the target's colour class's appearance, as last seen, leaves its configured range
  // (ColorModel::outOfRange, with the class's name); "" when it does not, or no colour target.
  const std::string& appearanceWarning() const { return appearance_warning_; }

 private:
  // The yaw of each trusted box (by object; not ok for the others), at most
  // orientation_max_per_frame of them, nearest the left image's centre first.
  std::vector<BoxYaw> estimateYaws(const ptzstereo::stereo_frame_t& m,
                                   const std::array<const FramePixels*, 2>& pixels,
                                   const std::vector<StereoObject>& objects,
                                   const std::vector<TrackMeasurement>& measurements,
                                   const std::vector<Region>& lr, const std::vector<Region>& rr,
                                   const CameraView& lv, const CameraView& rv);
  // The selector's choice after this frame's tracker update; *reason_changed when its reason did.
  int64_t chooseTarget(double t_s, bool* reason_changed);
  // The clicked object of this frame: a pending click's model started, or the model's object found.
  std::optional<PatchObject> clickedObject(int64_t seq, double t_s, const CropPixels crops[2],
                                           const CameraView& lv, const CameraView& rv,
                                           FrameOutputs* out);
  // After a request met by another target: a pending click is forgotten, and the clicked object's
  // model dropped unless the target is still of its class.
  void settleClick();
  // The three messages of a processed frame.
  void makeMessages(const ptzstereo::stereo_frame_t& m, double t_s, int64_t target_id,
                    const std::vector<Region>& lr, const std::vector<Region>& rr,
                    const std::vector<StereoObject>& objects, const std::vector<BoxYaw>& yaws,
                    const MarkerScan& markers, const std::vector<PatchObject>& people,
                    const std::optional<PatchObject>& clicked, const CameraView& lv,
                    FrameOutputs* out) const;
  void setCounters(int64_t target_id, int64_t target_index);
  // The target's colour class learns the colour of its regions in this frame (color_follow, or
  // for the appearance status); counters color_* and appearance_out_of_range_frames.
  void learnColour(double t_s, int64_t target_id, const std::vector<TrackMeasurement>& measurements,
                   const std::vector<StereoObject>& objects, const std::vector<Region>& lr,
                   const std::vector<Region>& rr);
  // The tracker's counts, the scanners' and their errors into counters_.
  void setTrackAndScanCounters();
  // The search for new objects that ended (wait: the running one's, once it ends) joins the
  // tracker. False and *why when it failed.
  bool absorbNewObjects(bool wait, std::string* why);

  DetectConfig config_;
  StereoRig rig_;
  Detector detector_;
  Tracker tracker_;
  std::vector<std::string> class_names_;  // the detector's, by class index
  TargetSelector selector_;
  WindowScanner windows_;
  MarkerScanner markers_;
  PeopleScanner people_;
  ClickedTracker clicked_;
  std::unique_ptr<NewObjectSearch> new_objects_;
  ColourBand pending_band_;  // the last frame's, for discover()
  // A click on no track, waiting for the next frame's pixels to start a model: its camera and the
  // head-frame direction of its pixel in the frame it was made on (the heads may turn meanwhile).
  std::optional<std::pair<Side, Eigen::Vector3d>> pending_click_;
  double clicked_seen_s_ = 0;  // when the clicked object was last found
  double last_t_s_ = -1e300;   // the newest frame's time (going back: a new run)
  // The views of the newest frames processed, by seq (the last the newest): a click names the
  // frame it was made on, a point on a track is judged in the newest.
  static constexpr size_t kViewsKept = 32;
  std::deque<std::pair<int64_t, std::pair<CameraView, CameraView>>> recent_views_;
  std::vector<double> processing_ms_, discovery_ms_;
  std::map<std::string, int64_t> scan_errors_;  // marker_errors, people_errors
  std::vector<double> orientation_us_;
  std::map<std::string, int64_t> counters_;
  std::vector<ColorModel> color_models_;  // by colour class index
  int64_t colour_target_id_ = -1;         // the target they learned from
  std::string appearance_warning_;
};

}  // namespace ptz::perception
