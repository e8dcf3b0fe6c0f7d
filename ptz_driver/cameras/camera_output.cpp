#include "ptz_driver/cameras/camera_output.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <utility>

#include "ptzstereo/process_status_t.hpp"

namespace ptz::driver {
namespace {

// The chip with the trigger's output line requested (before the pulser drives it).
std::unique_ptr<GpioLines> withOutput(std::unique_ptr<GpioLines> chip, const TriggerParams& t) {
  chip->requestOutput(t.line, "trigger_line", t.active_low);
  return chip;
}

PtzPose pose(const ptzstereo::ptz_head_state_t& h) {
  return {h.pan_rad, h.tilt_rad, h.zoom};
}

}  // namespace

std::array<SourceFactory, 2> captureFactories(CameraConfig* config, bool pass_jpeg,
                                              const std::shared_ptr<FrameNotifier>& notifier) {
  for (auto& c : config->capture) c.pass_jpeg = pass_jpeg;
  auto clock = std::make_shared<PlaybackClock>();
  std::array<SourceFactory, 2> factories;
  for (size_t s = 0; s < 2; ++s) {
    factories[s] = makeCaptureFactory(config->source[s], config->capture[s], clock, notifier);
  }
  return factories;
}

bool takePtzState(StereoCamera* camera, const ptzstereo::ptz_state_t& m) {
  return camera->onPtzState(m.utime, pose(m.left), pose(m.right));
}

int pollTimeoutMs(const StereoCamera& camera, int64_t now_utime, int max_ms) {
  const auto until = camera.heldUntilUtime();
  if (!until) return max_ms;
  const int64_t left_us = *until - now_utime;
  return static_cast<int>(std::clamp<int64_t>((left_us + 999) / 1000, 0, max_ms));
}

ptzstereo::image_t passedThroughImage(CapturedFrame* f, const PtzPose& pose) {
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

cv::Mat reducedDecode(const std::vector<uint8_t>& jpeg, int width, int preview_width_px) {
  int flag = cv::IMREAD_COLOR;
  if (width >= 8 * preview_width_px) {
    flag = cv::IMREAD_REDUCED_COLOR_8;
  } else if (width >= 4 * preview_width_px) {
    flag = cv::IMREAD_REDUCED_COLOR_4;
  } else if (width >= 2 * preview_width_px) {
    flag = cv::IMREAD_REDUCED_COLOR_2;
  }
  return cv::imdecode(jpeg, flag);
}

bool previewPixels(StampedPair* p, const ptzstereo::stereo_frame_t& msg, int preview_width_px) {
  for (auto [f, image] : {std::pair{&p->left, &msg.left}, {&p->right, &msg.right}}) {
    if (f->image.empty())
      f->image = reducedDecode(image->data, f->jpeg_size.width, preview_width_px);
  }
  return !p->left.image.empty() && !p->right.image.empty();
}

void PairWaits::add(const StampedPair& p, int64_t publish_utime) {
  wait_ms.push_back((publish_utime - p.first_arrival_utime) / 1000.0);
  ptz_wait_ms.push_back(p.ptz_wait_us / 1000.0);
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

TriggerLine::TriggerLine(std::unique_ptr<GpioLines> chip, const TriggerParams& t,
                         TriggerLog& pulses, PulseClock clock)
    : chip_(withOutput(std::move(chip), t)),
      pulses_(pulses),
      pulser_(*chip_, t, pulses, std::move(clock)),
      health_(t.line, 2.0) {
  pulser_.start();
}

void TriggerLine::report(int64_t now_utime, std::map<std::string, int64_t>* counters,
                         std::vector<double>* edge_late_ms, Health* h, std::string* message) {
  (*counters)["trigger_pulses"] = pulses_.pulses();
  (*counters)["trigger_missed_periods"] = pulser_.missedPeriods();
  (*counters)["trigger_io_errors"] = chip_->ioErrors();
  for (double late_s : pulser_.takeEdgeLatenessS()) edge_late_ms->push_back(late_s * 1e3);
  bool error = false;
  const std::string problem =
      health_.update(now_utime, chip_->ioErrors(), pulser_.missedPeriods(), &error);
  if (problem.empty()) return;
  const Health level = error ? Health::kError : Health::kWarn;
  if (static_cast<int>(level) > static_cast<int>(*h)) *h = level;
  *message += (message->empty() ? "" : "; ") + problem;
}

}  // namespace ptz::driver
