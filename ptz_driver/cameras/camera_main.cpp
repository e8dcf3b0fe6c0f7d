// ptz-camera: two real cameras (or recordings) -> STEREO_FRAME, exactly as ptz-sim publishes it,
// each image stamped with its camera's pan/tilt/zoom at capture from PTZ_STATE. Everything but
// the messages is the library's (stereo_camera.hpp, camera_output.hpp); this loop waits on LCM
// and on the readers.
#include <poll.h>

#include <cstdio>
#include <cstdlib>

#include "common/transport/transport.hpp"
#include "ptz_driver/cameras/camera_output.hpp"
#include "ptz_driver/cameras/stereo_camera.hpp"
#include "ptz_driver/emulators/emulated_gpio_chip.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::driver {
namespace {

constexpr int kStateQueue = 1000;  // PTZ_STATE messages waiting to be handled

class CameraNode {
 public:
  CameraNode(const Params& p, lcm::LCM* lcm)
      : lcm_(lcm),
        status_(lcm, p, "ptz-camera"),
        bulk_out_(p, *lcm),
        preview_(p),
        encoding_(imageEncodingFrom(p)),
        jpeg_quality_(p.getInt("jpeg_quality")),
        preview_due_(p.getDouble("preview_rate_hz")),
        preview_width_px_(p.getInt("preview_width_px")),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_state_(channel(p, channels::kPtzState)) {
    CameraConfig config = cameraConfigFrom(p);
    auto factories =
        captureFactories(&config, encoding_ == ptzstereo::image_t::ENCODING_JPEG, notifier_);
    // Subscribed before any source opens: states published from now on stamp the first frames.
    // Every state counts for the interpolation (unlike frames): each one, in order.
    states_ = std::make_unique<SafeSubscription<ptzstereo::ptz_state_t>>(
        *lcm_, ch_state_, status_,
        [this](const std::string& ch, const ptzstereo::ptz_state_t& m) { onState(ch, m); },
        Delivery::kEvery, kStateQueue);
    if (config.trigger.enabled()) startTrigger(config.trigger);
    camera_ = std::make_unique<StereoCamera>(config, std::move(factories), &pulses_);
  }

  int run() {
    status_.publishNow();  // up and subscribed
    while (!StopFlag::stopRequested()) {
      pollfd fds[2] = {{lcm_->getFileno(), POLLIN, 0}, {notifier_->fd(), POLLIN, 0}};
      // At least 20 Hz for timeouts and the status.
      ::poll(fds, 2, pollTimeoutMs(*camera_, wallUtime(), 50));
      // States first, so that the frames that woke us find the states published before them.
      if (fds[0].revents & POLLIN) {
        while (lcm_->handleTimeout(0) > 0) {
        }
      }
      notifier_->drain();
      const int64_t now = wallUtime();
      for (auto& pair : camera_->step(now)) publish(&pair);
      for (const auto& e : camera_->takeEvents())
        std::fprintf(stderr, "ptz-camera: %s\n", e.c_str());
      report(now);
      if (camera_->finished()) break;  // both files played to their end
    }
    report(wallUtime());
    status_.publishLast();
    return 0;
  }

 private:
  // The pulses start before the cameras open: their first frames already answer one.
  void startTrigger(const TriggerParams& t) {
    std::unique_ptr<GpioLines> chip;
    if (t.chip == "sim") {
      auto sim = std::make_unique<EmulatedGpioChip>(std::vector<EmulatedAxisSpec>{}, 0, 1e-4);
      sim->useClock(gpioClockS);
      sim->addOutput(t.line);
      chip = std::move(sim);
    } else {
      chip = openGpiodChip(t.chip, "ptz-camera", "trigger_chip");
    }
    trigger_ = std::make_unique<TriggerLine>(std::move(chip), t, pulses_, realPulseClock());
  }

  void onState(const std::string& ch, const ptzstereo::ptz_state_t& m) {
    if (!takePtzState(camera_.get(), m)) {
      status_.countDropped(ch, "not_newer");
      return;
    }
    status_.countIn(ch, (wallUtime() - m.utime) / 1000.0);
  }

  void publish(StampedPair* p) {
    ptzstereo::stereo_frame_t msg{};
    if (p->left.jpeg.empty() && p->right.jpeg.empty()) {
      msg = makeStereoFrame(p->left.capture_utime, seq_++, p->left.image, p->left_pose,
                            p->right.image, p->right_pose, encoding_, jpeg_quality_);
    } else {
      msg.utime = p->left.capture_utime;
      msg.seq = seq_++;
      msg.left = imageMessage(&p->left, p->left_pose);
      msg.right = imageMessage(&p->right, p->right_pose);
    }
    const bool preview = preview_due_.take(msg.utime);
    msg.publish_utime = wallUtime();
    status_.publishOn(bulk_out_.lcm(), ch_frame_, msg, (msg.publish_utime - msg.utime) / 1000.0);
    // Previews need pixels: a passed-through JPEG is decoded (reduced) only when one is due, and
    // after the frame went out, so that the loop never waits for it. Its schedule takes exactly
    // when preview_due_ does: the same rate and the same times.
    if (preview) {
      if (!previewPixels(p, msg, preview_width_px_)) {
        status_.increment("previews_undecodable");
      } else {
        preview_.maybePublish(status_, *lcm_, msg.utime, msg.seq, p->left.image, p->left_pose,
                              p->right.image, p->right_pose);
      }
    }
    waits_.add(*p, msg.publish_utime);
  }

  // A decoded image encoded as configured, or a source's JPEG as it is (moved into the message).
  ptzstereo::image_t imageMessage(CapturedFrame* f, const PtzPose& pose) {
    if (f->jpeg.empty()) return encodeImage(f->image, pose, encoding_, jpeg_quality_);
    return passedThroughImage(f, pose);
  }

  void report(int64_t now) {
    std::map<std::string, int64_t> counters = camera_->counters();
    std::string message;
    Health h = camera_->health(now, &message);
    if (trigger_) trigger_->report(now, &counters, &edge_late_ms_, &h, &message);
    status_.setCounters(counters);
    // How late the trigger's edges came after their periods' starts; from the first frame of a
    // pair arriving to its publication, and of that how long it was held for a PTZ_STATE.
    if (trigger_) status_.setPercentilesUs("trigger_late", &edge_late_ms_, 30);
    status_.setPercentilesUs("pair_wait", &waits_.wait_ms, 30);
    status_.setPercentilesUs("ptz_wait", &waits_.ptz_wait_ms, 30);
    status_.setState(statusState(h), message);
    // Sources log each of their events; a rig that does not pair has no event: rate-limited.
    const std::string no_pair = camera_->noPairMessage(now);
    if (!no_pair.empty()) log_.warn("no_pair", "ptz-camera: " + no_pair);
    status_.maybePublish();
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  FrameOutput bulk_out_;
  PreviewOutput preview_;
  RateLimitedLog log_;
  int8_t encoding_;
  int jpeg_quality_;
  RateSchedule preview_due_;  // mirrors preview_'s schedule
  int preview_width_px_;
  std::string ch_frame_, ch_state_;
  std::shared_ptr<FrameNotifier> notifier_ = std::make_shared<FrameNotifier>();
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_state_t>> states_;
  // Destroyed after the camera that reads the pulses; the line is left inactive.
  TriggerLog pulses_;
  std::unique_ptr<TriggerLine> trigger_;
  std::unique_ptr<StereoCamera> camera_;
  int64_t seq_ = 0;
  PairWaits waits_;
  std::vector<double> edge_late_ms_;
};

}  // namespace
}  // namespace ptz::driver

int main(int argc, char** argv) {
  using namespace ptz;
  Params params("ptz-camera",
                "Two cameras (V4L2, RTSP, GStreamer) or recordings (video files, image folders) "
                "-> STEREO_FRAME, paired by capture time and stamped with each camera's "
                "pan/tilt/zoom from PTZ_STATE; reconnects lost cameras with back-off.");
  addTransportParams(params);
  addFrameOutputParams(params);
  addPreviewParams(params);
  driver::declareCameraParams(params);
  addImageEncodingParams(params);
  return runProcess(argc, argv, params, [](const Params& p, lcm::LCM& lcm) {
    int rc = 0;
    {
      driver::CameraNode node(p, &lcm);
      rc = node.run();
    }  // its sources closed: a reader blocked in a driver is only now known to be abandoned
    if (driver::abandonedReaders() > 0) {
      // Such a reader must not run into the static destructors that exit() would run.
      std::fprintf(stderr, "ptz-camera: %d reader(s) still blocked in a driver at exit\n",
                   driver::abandonedReaders());
      std::fflush(nullptr);
      std::_Exit(rc);
    }
    return rc;
  });
}
