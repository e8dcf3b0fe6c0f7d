// ptz-view: a live viewer (OpenCV highgui; under X or Xvfb). It only subscribes: frames come
// with a queue of one and a frame it is too busy to draw is counted and skipped, so it never
// slows the loop. A frame is drawn once its detections and pose are in (or after max_wait_s).
// Keys: p pause/resume, n one frame while paused, s screenshot, q or Esc quit.
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdlib>
#include <deque>
#include <map>
#include <memory>

#include "common/transport.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "tools/view/viewer.hpp"

namespace ptz::tools {
namespace {

constexpr const char* kWindow = "ptz-view";

class ViewNode {
 public:
  ViewNode(const Params& p, lcm::LCM* lcm, StereoRig rig)
      : lcm_(lcm),
        status_(lcm, p, "ptz-view"),
        rig_(std::move(rig)),
        max_wait_us_(static_cast<int64_t>(p.getDouble("max_wait_s") * 1e6)),
        screenshot_dir_(p.getString("screenshot_dir")),
        screenshot_after_(p.getInt("screenshot_after_frames")),
        ch_frame_(channel(p, channels::kStereoFrame)) {
    frames_ = std::make_unique<SafeSubscription<ptzstereo::stereo_frame_t>>(
        *lcm_, ch_frame_, status_,
        [this](const std::string& ch, const ptzstereo::stereo_frame_t& m) { onFrame(ch, m); },
        Delivery::kNewest);
    detections_ = std::make_unique<SafeSubscription<ptzstereo::object_detections_t>>(
        *lcm_, channel(p, channels::kObjectDetections), status_,
        [this](const std::string&, const ptzstereo::object_detections_t& m) {
          detections_by_seq_[m.frame_seq] = m;
        });
    poses_ = std::make_unique<SafeSubscription<ptzstereo::object_pose_t>>(
        *lcm_, channel(p, channels::kObjectPose), status_,
        [this](const std::string&, const ptzstereo::object_pose_t& m) {
          poses_by_seq_[m.frame_seq] = m;
        });
    setpoints_ = std::make_unique<SafeSubscription<ptzstereo::ptz_setpoint_t>>(
        *lcm_, channel(p, channels::kPtzSetpoint), status_,
        [this](const std::string&, const ptzstereo::ptz_setpoint_t& m) { setpoint_ = m; });
    control_ = std::make_unique<SafeSubscription<ptzstereo::process_status_t>>(
        *lcm_, channel(p, "PROCESS_STATUS_PTZ_CONTROL"), status_,
        [this](const std::string&, const ptzstereo::process_status_t& m) {
          for (const auto& c : m.counters) {
            if (c.name == "delay_us_p50") delay_ms_p50_ = c.value / 1000.0;
            if (c.name == "delay_us_p99") delay_ms_p99_ = c.value / 1000.0;
          }
        });
    cv::namedWindow(kWindow, cv::WINDOW_AUTOSIZE | cv::WINDOW_GUI_NORMAL);
    cv::moveWindow(kWindow, 0, 0);
  }

  int run() {
    status_.publishNow();  // up and subscribed
    while (!StopFlag::stopRequested()) {
      handleNewest(*lcm_, 5);
      drawReady();
      status_.maybePublish();
      const int key = cv::waitKey(1) & 0xff;
      if (key == 'q' || key == 27) break;
      if (key == 'p' || key == ' ') paused_ = !paused_;
      if (key == 'n') step_ = true;
      if (key == 's') screenshot();
    }
    status_.publishNow();
    cv::destroyAllWindows();
    return 0;
  }

 private:
  struct Pending {
    ptzstereo::stereo_frame_t frame;
    int64_t received_us;
  };

  void onFrame(const std::string& ch, const ptzstereo::stereo_frame_t& m) {
    status_.countIn(ch, -1);
    const int64_t now = wallUtime();
    frame_times_us_.push_back(now);
    while (frame_times_us_.front() < now - 1'000'000) frame_times_us_.pop_front();
    if (paused_ && !step_) {
      status_.increment("frames_not_drawn");
      // Their detections and poses will never be drawn either.
      detections_by_seq_.erase(detections_by_seq_.begin(), detections_by_seq_.upper_bound(m.seq));
      poses_by_seq_.erase(poses_by_seq_.begin(), poses_by_seq_.upper_bound(m.seq));
      return;
    }
    // Kept as it came: only the frame that is drawn is decoded (a newer one replaces it).
    if (pending_) status_.increment("frames_not_drawn");
    pending_ = Pending{m, now};
  }

  void drawReady() {
    if (!pending_) return;
    const ptzstereo::stereo_frame_t& m = pending_->frame;
    const int64_t seq = m.seq;
    const bool complete = detections_by_seq_.count(seq) && poses_by_seq_.count(seq);
    if (!complete && wallUtime() - pending_->received_us < max_wait_us_) return;
    ViewInput in;
    std::string error;
    // The rig's size bounds what decoding may cost (a small JPEG can claim any size).
    if (!checkFrameMatchesRig(m, rig_.left.width, rig_.left.height, &error)) {
      status_.countDropped(ch_frame_, "size_mismatch");
      log_.warn("size", "ptz-view: frame " + std::to_string(seq) + " not drawn: " + error);
      pending_.reset();
      return;
    }
    if (!decodeImage(m.left, &in.left, &error) || !decodeImage(m.right, &in.right, &error) ||
        in.left.type() != CV_8UC3) {
      status_.countDropped(ch_frame_, "bad_image");
      log_.warn("image", "ptz-view: frame " + std::to_string(seq) + " not drawn: " + error);
      pending_.reset();
      return;
    }
    in.left_ptz = {m.left.pan_rad, m.left.tilt_rad, m.left.zoom};
    in.right_ptz = {m.right.pan_rad, m.right.tilt_rad, m.right.zoom};
    in.seq = seq;
    if (detections_by_seq_.count(seq)) in.detections = detections_by_seq_[seq];
    if (poses_by_seq_.count(seq)) in.pose = poses_by_seq_[seq];
    in.setpoint = setpoint_;
    in.delay_ms_p50 = delay_ms_p50_;
    in.delay_ms_p99 = delay_ms_p99_;
    in.frame_rate_hz = static_cast<double>(frame_times_us_.size());
    const int64_t now = wallUtime();
    drawn_times_us_.push_back(now);
    while (drawn_times_us_.front() < now - 1'000'000) drawn_times_us_.pop_front();
    in.drawn_rate_hz = static_cast<double>(drawn_times_us_.size());
    in.frames_dropped = status_.counter("frames_not_drawn");
    in.paused = paused_;
    canvas_ = drawView(rig_, in);
    canvas_seq_ = seq;
    cv::imshow(kWindow, canvas_);
    status_.increment("frames_drawn");
    status_.setCounter("last_frame_drawn", seq);
    pending_.reset();
    step_ = false;
    // Only the frames still to come are worth keeping.
    detections_by_seq_.erase(detections_by_seq_.begin(), detections_by_seq_.upper_bound(seq));
    poses_by_seq_.erase(poses_by_seq_.begin(), poses_by_seq_.upper_bound(seq));
    if (screenshot_after_ > 0 && status_.counter("frames_drawn") == screenshot_after_) {
      screenshot();
    }
  }

  void screenshot() {
    if (canvas_.empty()) return;
    const std::string path = screenshot_dir_ + "/ptz-view-" + std::to_string(canvas_seq_) + ".png";
    if (cv::imwrite(path, canvas_)) {
      status_.increment("screenshots");
      std::printf("ptz-view: screenshot %s\n", path.c_str());
      std::fflush(stdout);
    } else {
      log_.warn("screenshot", "ptz-view: cannot write '" + path + "'");
    }
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  RateLimitedLog log_;
  StereoRig rig_;
  int64_t max_wait_us_;
  std::string screenshot_dir_;
  int64_t screenshot_after_;
  std::string ch_frame_;
  std::optional<Pending> pending_;
  std::map<int64_t, ptzstereo::object_detections_t> detections_by_seq_;
  std::map<int64_t, ptzstereo::object_pose_t> poses_by_seq_;
  std::optional<ptzstereo::ptz_setpoint_t> setpoint_;
  double delay_ms_p50_ = NAN, delay_ms_p99_ = NAN;
  std::deque<int64_t> frame_times_us_, drawn_times_us_;
  cv::Mat canvas_;
  int64_t canvas_seq_ = 0;
  bool paused_ = false, step_ = false;
  std::unique_ptr<SafeSubscription<ptzstereo::stereo_frame_t>> frames_;
  std::unique_ptr<SafeSubscription<ptzstereo::object_detections_t>> detections_;
  std::unique_ptr<SafeSubscription<ptzstereo::object_pose_t>> poses_;
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_setpoint_t>> setpoints_;
  std::unique_ptr<SafeSubscription<ptzstereo::process_status_t>> control_;
};

}  // namespace
}  // namespace ptz::tools

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-view",
                "Live viewer: both camera images with detections, image centre, the target's "
                "epipolar line, PTZ state and setpoint, 3D position, loop delay and rates. "
                "Keys: p pause, n step, s screenshot, q quit. Needs X (or Xvfb).");
  addTransportParams(params);
  params.add("rig_file", "", "rig file (OpenCV YAML); empty: the built-in default rig");
  params.add("max_wait_s", 0.2, "s", "draw a frame without its detections after this long",
             Range::atLeast(0));
  params.add("screenshot_dir", ".", "where the s key (and screenshot_after_frames) saves PNGs");
  params.add("screenshot_after_frames", 0, "", "save one screenshot after this many frames",
             Range::atLeast(0));
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    const char* display = std::getenv("DISPLAY");
    if (!display || !*display) {
      throw ConfigError("no X display (DISPLAY is not set): run it under X, or xvfb-run ptz-view");
    }
    tools::ViewNode node(p, &lcm, rigFromParams(p));
    return node.run();
  });
}
