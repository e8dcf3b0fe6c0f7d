// ptz-detect: STEREO_FRAME -> OBJECT_DETECTIONS + OBJECT_POSE + OBJECT_TRACKS. Always the newest
// fresh frame (those waiting are drained, older ones dropped as superseded, late ones as stale);
// every output carries the source frame's utime and seq; bad frames are dropped, counted and warned
// about, never fatal. The tracker gives objects identities; the target is one track, locked until
// it is gone (TARGET_SELECT changes it); OBJECT_POSE's target_index is that track's object when a
// trusted measurement updated it in this frame. The work on a frame is DetectPipeline's
// (detect_pipeline.hpp); here: flags and config, LCM in and out, the status.
#include <opencv2/core/utility.hpp>

#include <cstdio>
#include <memory>
#include <string>
#include <utility>

#include "common/freshness.hpp"
#include "common/transport/intake.hpp"
#include "common/transport/transport.hpp"
#include "perception/detect/detect_params.hpp"
#include "perception/detect/detect_pipeline.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"

namespace ptz::perception {
namespace {

class DetectNode {
 public:
  DetectNode(const Params& p, lcm::LCM* lcm, DetectConfig config, StereoRig rig)
      : lcm_(lcm),
        status_(lcm, p, "ptz-detect"),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_detections_(channel(p, channels::kObjectDetections)),
        ch_pose_(channel(p, channels::kObjectPose)),
        ch_tracks_(channel(p, channels::kObjectTracks)),
        ch_select_(channel(p, channels::kTargetSelect)),
        intake_(status_, ch_frame_, freshnessFrom(p, "frame"), {rig.left.width, rig.left.height},
                p.getPath("rig_file")),
        select_gate_(status_, freshnessFrom(p, "select"), "TARGET_SELECT", "", CaptureClock::kWall),
        pipeline_(std::move(config), std::move(rig)) {
    // Always the newest frame, never a backlog.
    frames_ = std::make_unique<SafeSubscription<ptzstereo::stereo_frame_t>>(
        *lcm_, ch_frame_, status_,
        [this](const std::string&, const ptzstereo::stereo_frame_t& m) { onFrame(m); },
        Delivery::kNewest);
    selects_ = std::make_unique<SafeSubscription<ptzstereo::target_select_t>>(
        *lcm_, ch_select_, status_,
        [this](const std::string&, const ptzstereo::target_select_t& m) { onSelect(m); });
    status_.expectInput(ch_frame_);
  }

  int run() { return serveUntilStopped(*lcm_, status_); }

 private:
  void onFrame(const ptzstereo::stereo_frame_t& m) {
    const int64_t received = wallUtime();
    // Fresh, well-formed, of the rig's size and in colour before a pixel is decoded: the rig's
    // size bounds what a frame may cost.
    if (!intake_.accept(m, received)) return;
    FrameOutputs out;
    std::string why;
    if (!pipeline_.process(m, &out, &why)) {
      intake_.drop(m.seq, "bad_image", why);
      return;
    }
    status_.setCounters(pipeline_.counters());
    // A class whose object's colour leaves its configured range: the user's config needs a look.
    const std::string& appearance = pipeline_.appearanceWarning();
    if (appearance != appearance_) {
      appearance_ = appearance;
      status_.setState(appearance.empty() ? ptzstereo::process_status_t::STATE_OK
                                          : ptzstereo::process_status_t::STATE_WARN,
                       appearance);
    }
    if (!appearance.empty()) log_.warn("appearance", "ptz-detect: " + appearance);
    if (!out.new_objects_note.empty()) {
      log_.warn("discover",
                "ptz-detect: the search for new objects failed: " + out.new_objects_note);
    }
    if (!out.click_note.empty()) {
      std::fprintf(stderr, "ptz-detect: click: %s\n", out.click_note.c_str());
    }
    if (!intake_.stillFresh(m, wallUtime())) return;  // went stale while processed: not answered
    // Counted in once accepted: every message is either in or dropped, never both.
    status_.countIn(ch_frame_, latencyMs(m.utime, received));
    if (out.target_reason_changed) {
      std::fprintf(stderr, "ptz-detect: target: %s\n", pipeline_.targetReason().c_str());
    }
    // ptz-control's input first: the chain does not wait for the other two to be encoded and sent.
    if (!publishWhileFresh(m, ch_tracks_, &out.tracks)) return;
    if (!publishWhileFresh(m, ch_pose_, &out.pose)) return;
    publishWhileFresh(m, ch_detections_, &out.detections);
    // New tags, faces and people: once the frame's messages are out, off their latency; beside
    // the next frames, unless the frames are to be repeatable (not on the wall clock: sim time).
    if (!pipeline_.discover(m, !captureOnWallClock(m.utime, received), &why)) {
      log_.warn("discover", "ptz-detect: the search for new objects failed: " + why);
    }
    status_.setCounters(pipeline_.counters());
    if (!thread_problem_said_) {
      const std::string problem = pipeline_.newObjectsThreadProblem();
      if (!problem.empty()) {
        std::fprintf(stderr,
                     "ptz-detect: the search for new objects runs at the frames' priority (%s): "
                     "new_objects_thread_nice is -100 in the status\n",
                     problem.c_str());
        thread_problem_said_ = true;
      }
    }
  }

  // A process stopped between two publishes (a send wakes the receivers, whose answer may stop
  // this one) must not send the rest seconds later: each answer is judged again as it goes.
  template <class Msg>
  bool publishWhileFresh(const ptzstereo::stereo_frame_t& frame, const std::string& ch, Msg* msg) {
    msg->publish_utime = wallUtime();
    if (!intake_.mayAnswer(frame, msg->publish_utime)) return false;
    status_.publish(ch, *msg, latencyMs(msg->utime, msg->publish_utime));
    return true;
  }

  void onSelect(const ptzstereo::target_select_t& m) {
    const int64_t received = wallUtime();
    if (!select_gate_.admit(ch_select_, m.utime, m.publish_utime, m.frame_seq, received)) return;
    std::string why;
    if (!pipeline_.select(m, &why)) {
      status_.countDropped(ch_select_, "refused");
      const int64_t id = pipeline_.targetId();
      log_.warn("select", "ptz-detect: TARGET_SELECT refused: " + why + "; the target stays " +
                              (id >= 0 ? "track " + std::to_string(id) : std::string("none")));
      return;
    }
    status_.countIn(ch_select_, latencyMs(m.utime, received));
    log_.warn("selected", "ptz-detect: target: " + pipeline_.targetReason());
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  RateLimitedLog log_;
  std::string ch_frame_, ch_detections_, ch_pose_, ch_tracks_, ch_select_;
  FrameIntake intake_;
  FreshnessGate select_gate_;
  DetectPipeline pipeline_;
  std::string appearance_;  // the appearance warning in the status
  bool thread_problem_said_ = false;
  std::unique_ptr<SafeSubscription<ptzstereo::stereo_frame_t>> frames_;
  std::unique_ptr<SafeSubscription<ptzstereo::target_select_t>> selects_;
};

}  // namespace
}  // namespace ptz::perception

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-detect",
                "Finds coloured objects of known shape in both images of every "
                "STEREO_FRAME, pairs them along epipolar lines, triangulates them "
                "and publishes OBJECT_DETECTIONS and OBJECT_POSE.");
  addTransportParams(params);
  declareRigParams(params);
  perception::declareDetectParams(params);
  // One OpenCV thread per calling thread: both cameras run on forBothCameras' threads, and the
  // niced search for new objects must not borrow OpenCV's pool (made at the frames' priority).
  cv::setNumThreads(1);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    perception::DetectConfig config = perception::DetectConfig::fromParams(p);
    perception::DetectNode node(p, &lcm, std::move(config), rigFromParams(p));
    return node.run();
  });
}
