// ptz-camera: two real cameras (or recordings) -> STEREO_FRAME, exactly as ptz-sim publishes it,
// each image stamped with its camera's pan/tilt/zoom at capture from PTZ_STATE. Everything but
// the messages is the library's (stereo_camera.hpp); this loop waits on LCM and on the readers.
#include <poll.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "common/transport.hpp"
#include "ptz_driver/cameras/stereo_camera.hpp"
#include "ptz_driver/emulators/emulated_gpio_chip.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::driver {
namespace {

constexpr int kStateQueue = 1000;  // PTZ_STATE messages waiting to be handled

PtzPose pose(const ptzstereo::ptz_head_state_t& h) {
  return {h.pan_rad, h.tilt_rad, h.zoom};
}

int8_t statusState(Health h) {
  switch (h) {
    case Health::kOk:
      return ptzstereo::process_status_t::STATE_OK;
    case Health::kWarn:
      return ptzstereo::process_status_t::STATE_WARN;
    case Health::kError:
      break;
  }
  return ptzstereo::process_status_t::STATE_ERROR;
}

class CameraNode {
 public:
  CameraNode(const Params& p, lcm::LCM* lcm)
      : lcm_(lcm),
        status_(lcm, p, "ptz-camera"),
        bulk_out_(p, *lcm),
        preview_(p),
        encoding_(imageEncodingFrom(p)),
        jpeg_quality_(p.getInt("jpeg_quality")),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_state_(channel(p, channels::kPtzState)) {
    const CameraConfig config = cameraConfigFrom(p);
    auto clock = std::make_shared<PlaybackClock>();
    std::array<SourceFactory, 2> factories;
    for (size_t s = 0; s < 2; ++s) {
      factories[s] = makeCaptureFactory(config.source[s], config.capture[s], clock, notifier_);
    }
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
      ::poll(fds, 2, pollTimeoutMs());
      // States first, so that the frames that woke us find the states published before them.
      if (fds[0].revents & POLLIN) {
        while (lcm_->handleTimeout(0) > 0) {
        }
      }
      notifier_->drain();
      const int64_t now = wallUtime();
      for (auto& pair : camera_->step(now)) publish(pair);
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
  // At least 20 Hz for timeouts and the status; sooner when a held pair's wait for its
  // PTZ_STATE runs out.
  int pollTimeoutMs() const {
    int ms = 50;
    if (const auto until = camera_->heldUntilUtime()) {
      const int64_t left_us = *until - wallUtime();
      ms = static_cast<int>(std::clamp<int64_t>((left_us + 999) / 1000, 0, ms));
    }
    return ms;
  }

  // The pulses start before the cameras open: their first frames already answer one.
  void startTrigger(const TriggerParams& t) {
    if (t.chip == "sim") {
      auto chip = std::make_unique<EmulatedGpioChip>(std::vector<EmulatedAxisSpec>{}, 0, 1e-4);
      chip->useClock(gpioClockS);
      chip->addOutput(t.line);
      trigger_chip_ = std::move(chip);
    } else {
      trigger_chip_ = openGpiodChip(t.chip, "ptz-camera", "trigger_chip");
    }
    trigger_chip_->requestOutput(t.line, "trigger_line", t.active_low);
    trigger_health_.emplace(t.line, 2.0);
    pulser_ = std::make_unique<TriggerPulser>(*trigger_chip_, t, pulses_, realPulseClock());
    pulser_->start();
  }

  void onState(const std::string& ch, const ptzstereo::ptz_state_t& m) {
    if (!camera_->onPtzState(m.utime, pose(m.left), pose(m.right))) {
      status_.countDropped(ch, "not_newer");
      return;
    }
    status_.countIn(ch, (wallUtime() - m.utime) / 1000.0);
  }

  void publish(const StampedPair& p) {
    ptzstereo::stereo_frame_t msg =
        makeStereoFrame(p.left.capture_utime, seq_++, p.left.image, p.left_pose, p.right.image,
                        p.right_pose, encoding_, jpeg_quality_);
    msg.publish_utime = wallUtime();
    status_.publishOn(bulk_out_.lcm(), ch_frame_, msg, (msg.publish_utime - msg.utime) / 1000.0);
    preview_.maybePublish(status_, *lcm_, msg.utime, msg.seq, p.left.image, p.left_pose,
                          p.right.image, p.right_pose);
    wait_ms_.push_back((msg.publish_utime - p.first_arrival_utime) / 1000.0);
    ptz_wait_ms_.push_back(p.ptz_wait_us / 1000.0);
  }

  void report(int64_t now) {
    for (const auto& [name, value] : camera_->counters()) status_.setCounter(name, value);
    if (pulser_) {
      status_.setCounter("trigger_pulses", pulses_.pulses());
      status_.setCounter("trigger_missed_periods", pulser_->missedPeriods());
      status_.setCounter("trigger_io_errors", trigger_chip_->ioErrors());
      for (double late_s : pulser_->takeEdgeLatenessS()) edge_late_ms_.push_back(late_s * 1e3);
      // How late the edges came after their periods' starts.
      status_.setPercentilesUs("trigger_late", &edge_late_ms_, 30);
    }
    // From the first frame of a pair arriving to its publication, and of that how long it was
    // held for a PTZ_STATE after the capture.
    status_.setPercentilesUs("pair_wait", &wait_ms_, 30);
    status_.setPercentilesUs("ptz_wait", &ptz_wait_ms_, 30);
    std::string message;
    Health h = camera_->health(now, &message);
    if (pulser_) addTriggerHealth(now, &h, &message);
    status_.setState(statusState(h), message);
    // Sources log each of their events; a rig that does not pair has no event: rate-limited.
    const std::string no_pair = camera_->noPairMessage(now);
    if (!no_pair.empty()) log_.warn("no_pair", "ptz-camera: " + no_pair);
    status_.maybePublish();
  }

  void addTriggerHealth(int64_t now, Health* h, std::string* message) {
    bool error = false;
    const std::string problem =
        trigger_health_->update(now, trigger_chip_->ioErrors(), pulser_->missedPeriods(), &error);
    if (problem.empty()) return;
    const Health level = error ? Health::kError : Health::kWarn;
    if (static_cast<int>(level) > static_cast<int>(*h)) *h = level;
    *message += (message->empty() ? "" : "; ") + problem;
  }

  lcm::LCM* lcm_;
  StatusReporter status_;
  FrameOutput bulk_out_;
  PreviewOutput preview_;
  RateLimitedLog log_;
  int8_t encoding_;
  int jpeg_quality_;
  std::string ch_frame_, ch_state_;
  std::shared_ptr<FrameNotifier> notifier_ = std::make_shared<FrameNotifier>();
  std::unique_ptr<SafeSubscription<ptzstereo::ptz_state_t>> states_;
  // Destroyed after the camera that reads the pulses; the pulser leaves the line inactive.
  std::unique_ptr<GpioLines> trigger_chip_;
  TriggerLog pulses_;
  std::unique_ptr<TriggerPulser> pulser_;
  std::optional<TriggerLineHealth> trigger_health_;
  std::unique_ptr<StereoCamera> camera_;
  int64_t seq_ = 0;
  std::vector<double> wait_ms_, ptz_wait_ms_, edge_late_ms_;
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
