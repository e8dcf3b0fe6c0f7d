// ptz-view: a live viewer (OpenCV highgui; under X or Xvfb). It only subscribes: frames come
// with a queue of one and a frame it is too busy to draw is counted and skipped, so it never
// slows the loop. A frame is drawn once its detections, pose and tracks are in (or after
// max_wait_s). Keys: p pause/resume, n one frame while paused, s screenshot, q or Esc quit. A left
// click on either image asks ptz-detect to follow the object under it (TARGET_SELECT).
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <memory>

#include "common/transport/transport.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "tools/view/view_state.hpp"
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
        screenshot_dir_(p.getString("screenshot_dir")),
        screenshot_after_(p.getInt("screenshot_after_frames")),
        max_window_width_px_(p.getInt("max_window_width_px")),
        preview_(p.getBool("preview")),
        ch_frame_(channel(p, preview_ ? channels::kStereoPreview : channels::kStereoFrame)),
        ch_select_(channel(p, channels::kTargetSelect)),
        state_(static_cast<int64_t>(p.getDouble("max_wait_s") * 1e6)) {
    frames_ = std::make_unique<SafeSubscription<ptzstereo::stereo_frame_t>>(
        *lcm_, ch_frame_, status_,
        [this](const std::string& ch, const ptzstereo::stereo_frame_t& m) { onFrame(ch, m); },
        Delivery::kNewest);
    detections_ = std::make_unique<SafeSubscription<ptzstereo::object_detections_t>>(
        *lcm_, channel(p, channels::kObjectDetections), status_,
        [this](const std::string&, const ptzstereo::object_detections_t& m) {
          state_.onDetections(m);
        });
    poses_ = std::make_unique<SafeSubscription<ptzstereo::object_pose_t>>(
        *lcm_, channel(p, channels::kObjectPose), status_,
        [this](const std::string&, const ptzstereo::object_pose_t& m) { state_.onPose(m); });
    tracks_ = std::make_unique<SafeSubscription<ptzstereo::object_tracks_t>>(
        *lcm_, channel(p, channels::kObjectTracks), status_,
        [this](const std::string&, const ptzstereo::object_tracks_t& m) { state_.onTracks(m); });
    control_states_ = std::make_unique<SafeSubscription<ptzstereo::control_state_t>>(
        *lcm_, channel(p, channels::kControlState), status_,
        [this](const std::string&, const ptzstereo::control_state_t& m) {
          state_.onControlState(m);
        });
    setpoints_ = std::make_unique<SafeSubscription<ptzstereo::ptz_setpoint_t>>(
        *lcm_, channel(p, channels::kPtzSetpoint), status_,
        [this](const std::string&, const ptzstereo::ptz_setpoint_t& m) { state_.onSetpoint(m); });
    control_ = std::make_unique<SafeSubscription<ptzstereo::process_status_t>>(
        *lcm_, channel(p, "PROCESS_STATUS_PTZ_CONTROL"), status_,
        [this](const std::string&, const ptzstereo::process_status_t& m) {
          state_.onControlStatus(m);
        });
    // Resizable, so that two 1080p images fit a screen; HighGUI maps clicks back to the canvas.
    cv::namedWindow(kWindow, cv::WINDOW_NORMAL | cv::WINDOW_KEEPRATIO | cv::WINDOW_GUI_NORMAL);
    cv::moveWindow(kWindow, 0, 0);
    cv::setMouseCallback(kWindow, &ViewNode::onMouse, this);
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
  // A left click on the shown frame: TARGET_SELECT for the pixel under it (highgui calls this
  // from waitKey, on the loop's thread).
  static void onMouse(int event, int x, int y, int, void* self) {
    if (event == cv::EVENT_LBUTTONDOWN) static_cast<ViewNode*>(self)->click(x, y);
  }
  void click(int x, int y) {
    if (canvas_.empty()) return;
    const auto m = clickToSelect(x, y, canvas_.cols / 2, canvas_.rows - kPanelHeightPx, canvas_seq_,
                                 wallUtime());
    if (!m) return;
    if (!status_.publish(ch_select_, *m)) return;
    status_.increment("target_selects");
    std::printf("ptz-view: TARGET_SELECT %s image (%.0f, %.0f) of frame %lld\n",
                m->camera == ptzstereo::target_select_t::CAMERA_LEFT ? "left" : "right", m->x_px,
                m->y_px, static_cast<long long>(m->frame_seq));
    std::fflush(stdout);
  }

  void onFrame(const std::string& ch, const ptzstereo::stereo_frame_t& m) {
    status_.countIn(ch, -1);
    state_.onFrame(m, wallUtime(), paused_ && !step_);
    if (state_.framesNotDrawn() > 0)
      status_.setCounter("frames_not_drawn", state_.framesNotDrawn());
  }

  void drawReady() {
    const int64_t now = wallUtime();
    const ptzstereo::stereo_frame_t* m = state_.ready(now);
    if (!m) return;
    const int64_t seq = m->seq;
    ViewInput in = state_.input(now, paused_);
    std::string error;
    // The rig's size bounds what decoding may cost (a small JPEG can claim any size).
    if (!(preview_ ? checkPreviewMatchesRig(*m, rig_.left.width, rig_.left.height, &error)
                   : checkFrameMatchesRig(*m, rig_.left.width, rig_.left.height, &error))) {
      status_.countDropped(ch_frame_, "size_mismatch");
      log_.warn("size", "ptz-view: frame " + std::to_string(seq) + " not drawn: " + error);
      state_.done(false, now);
      return;
    }
    if (!decodeImage(m->left, &in.left, &error) || !decodeImage(m->right, &in.right, &error) ||
        in.left.type() != CV_8UC3) {
      status_.countDropped(ch_frame_, "bad_image");
      log_.warn("image", "ptz-view: frame " + std::to_string(seq) + " not drawn: " + error);
      state_.done(false, now);
      return;
    }
    if (preview_) {  // drawn at the rig's size: the detections are in its pixels
      const cv::Size rig_size(rig_.left.width, rig_.left.height);
      cv::resize(in.left, in.left, rig_size, 0, 0, cv::INTER_LINEAR);
      cv::resize(in.right, in.right, rig_size, 0, 0, cv::INTER_LINEAR);
    }
    canvas_ = drawView(rig_, in);
    canvas_seq_ = seq;
    state_.done(true, now);
    if (canvas_.size() != window_canvas_size_) {  // the first frame, or another image size
      window_canvas_size_ = canvas_.size();
      const double scale = std::min(1.0, max_window_width_px_ / canvas_.cols);
      cv::resizeWindow(kWindow, static_cast<int>(canvas_.cols * scale),
                       static_cast<int>(canvas_.rows * scale));
    }
    cv::imshow(kWindow, canvas_);
    status_.increment("frames_drawn");
    status_.setCounter("last_frame_drawn", seq);
    step_ = false;
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
  std::string screenshot_dir_;
  int64_t screenshot_after_;
  double max_window_width_px_;
  bool preview_;
  std::string ch_frame_, ch_select_;
  ViewState state_;
  cv::Mat canvas_;
  cv::Size window_canvas_size_;  // the canvas size the window was last sized for
  int64_t canvas_seq_ = 0;
  bool paused_ = false, step_ = false;
  std::unique_ptr<SafeSubscription<ptzstereo::stereo_frame_t>> frames_;
  std::unique_ptr<SafeSubscription<ptzstereo::object_detections_t>> detections_;
  std::unique_ptr<SafeSubscription<ptzstereo::object_pose_t>> poses_;
  std::unique_ptr<SafeSubscription<ptzstereo::object_tracks_t>> tracks_;
  std::unique_ptr<SafeSubscription<ptzstereo::control_state_t>> control_states_;
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_setpoint_t>> setpoints_;
  std::unique_ptr<SafeSubscription<ptzstereo::process_status_t>> control_;
};

}  // namespace
}  // namespace ptz::tools

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-view",
                "Live viewer: both camera images with detections, tracks (ids, the target), image "
                "centre, the target's epipolar line, PTZ state and setpoint, 3D position, the "
                "controller's state, loop delay and rates. Keys: p pause, n step, s screenshot, "
                "q quit; a left click on an image selects the object under it. Needs X (or "
                "Xvfb).");
  addTransportParams(params);
  declareRigParams(params);
  params.add("max_wait_s", 0.2, "s",
             "draw a frame without its detections, pose or tracks after this long",
             Range::atLeast(0));
  params.add("preview", false,
             "draw STEREO_PREVIEW (the small copies a camera host sends over a LAN, scaled up) "
             "instead of STEREO_FRAME");
  params.add("max_window_width_px", 1920, "px",
             "the window is scaled down to this width when the two images are wider (1080p)",
             Range::between(320, 16384));
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
