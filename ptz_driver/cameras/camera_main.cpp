// ptz-camera: two real cameras (or recordings) -> STEREO_FRAME, exactly as ptz-sim publishes it,
// each image stamped with its camera's pan/tilt/zoom at capture from PTZ_STATE. Everything but
// the messages is the library's (stereo_camera.hpp); this loop waits on LCM and on the readers.
#include <poll.h>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "common/transport/transport.hpp"
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
        preview_due_(p.getDouble("preview_rate_hz")),
        preview_width_px_(p.getInt("preview_width_px")),
        ch_frame_(channel(p, channels::kStereoFrame)),
        ch_state_(channel(p, channels::kPtzState)) {
    CameraConfig config = cameraConfigFrom(p);
    // Recorded JPEGs of the published size go out as they are: no decode, no re-encode.
    for (auto& c : config.capture) c.pass_jpeg = encoding_ == ptzstereo::image_t::ENCODING_JPEG;
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
      for (auto [f, image] : {std::pair{&p->left, &msg.left}, {&p->right, &msg.right}}) {
        if (f->image.empty()) f->image = reducedDecode(image->data, f->jpeg_size.width);
      }
      if (p->left.image.empty() || p->right.image.empty()) {
        status_.increment("previews_undecodable");
      } else {
        preview_.maybePublish(status_, *lcm_, msg.utime, msg.seq, p->left.image, p->left_pose,
                              p->right.image, p->right_pose);
      }
    }
    wait_ms_.push_back((msg.publish_utime - p->first_arrival_utime) / 1000.0);
    ptz_wait_ms_.push_back(p->ptz_wait_us / 1000.0);
  }

  // A decoded image encoded as configured, or a source's JPEG as it is (moved into the message).
  ptzstereo::image_t imageMessage(CapturedFrame* f, const PtzPose& pose) {
    if (f->jpeg.empty()) return encodeImage(f->image, pose, encoding_, jpeg_quality_);
    ptzstereo::image_t m{};
    m.width = f->jpeg_size.width;
    m.height = f->jpeg_size.height;
    m.pixel_format = ptzstereo::image_t::PIXEL_BGR8;  // what a decoder makes of 3 components
    m.row_stride = m.width * 3;                       // as encodeImage sets it
    m.encoding = ptzstereo::image_t::ENCODING_JPEG;
    m.pan_rad = pose.pan_rad;
    m.tilt_rad = pose.tilt_rad;
    m.zoom = pose.zoom;
    m.data = std::move(f->jpeg);
    m.data_size = static_cast<int32_t>(m.data.size());
    return m;
  }

  // libjpeg's DCT scaling: up to 8x smaller, still at least the preview's width.
  cv::Mat reducedDecode(const std::vector<uint8_t>& jpeg, int width) const {
    int flag = cv::IMREAD_COLOR;
    if (width >= 8 * preview_width_px_) {
      flag = cv::IMREAD_REDUCED_COLOR_8;
    } else if (width >= 4 * preview_width_px_) {
      flag = cv::IMREAD_REDUCED_COLOR_4;
    } else if (width >= 2 * preview_width_px_) {
      flag = cv::IMREAD_REDUCED_COLOR_2;
    }
    return cv::imdecode(jpeg, flag);
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
  RateSchedule preview_due_;  // mirrors preview_'s schedule
  int preview_width_px_;
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
