// What ptz-camera makes of its pairs and of its state for the messages, without LCM: a
// recorded JPEG as an image message byte for byte, the reduced decode a preview needs, the
// pairs' waits, the trigger line it drives and its counters and health for the status.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ptz_driver/cameras/stereo_camera.hpp"
#include "ptz_driver/cameras/trigger.hpp"
#include "ptz_driver/io/gpio_lines.hpp"
#include "ptzstereo/image_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::driver {

// Both capture sources on one playback clock, waking `notifier`; with pass_jpeg (JPEG published)
// recorded JPEGs of the published size go out as they are: no decode, no re-encode.
std::array<SourceFactory, 2> captureFactories(CameraConfig* config, bool pass_jpeg,
                                              const std::shared_ptr<FrameNotifier>& notifier);
// A PTZ_STATE into the camera's history; false (not used) when not after the newest.
bool takePtzState(StereoCamera* camera, const ptzstereo::ptz_state_t& m);
// How long the loop may wait (ms): at most max_ms, less when a held pair's wait for its
// PTZ_STATE runs out sooner.
int pollTimeoutMs(const StereoCamera& camera, int64_t now_utime, int max_ms);

// A source's JPEG as it is (moved into the message), stamped with pose; the size and pixel
// format as encodeImage sets them for a decoded image.
ptzstereo::image_t passedThroughImage(CapturedFrame* f, const PtzPose& pose);
// libjpeg's DCT scaling: up to 8x smaller, still at least preview_width_px wide.
cv::Mat reducedDecode(const std::vector<uint8_t>& jpeg, int width, int preview_width_px);
// Both images of a published pair as pixels for a preview (a passed-through JPEG decoded from
// msg, reduced); false when one does not decode.
bool previewPixels(StampedPair* p, const ptzstereo::stereo_frame_t& msg, int preview_width_px);

// Per published pair: from the first frame's arrival to publication, and of that how long it
// was held for a PTZ_STATE after the capture (ms, for the status's percentiles).
struct PairWaits {
  std::vector<double> wait_ms, ptz_wait_ms;
  void add(const StampedPair& p, int64_t publish_utime);
};

// process_status_t::STATE_* of a health.
int8_t statusState(Health h);

// The hardware trigger line: pulses at the configured rate on a chip the main opened (a GPIO
// chip or, for `sim`, the emulated one), logged in `pulses` (which must outlive it). Started at
// once; the line is left inactive when it goes.
class TriggerLine {
 public:
  TriggerLine(std::unique_ptr<GpioLines> chip, const TriggerParams& t, TriggerLog& pulses,
              PulseClock clock);
  // Its counters and edge lateness (ms), and its health raising h and adding to message.
  void report(int64_t now_utime, std::map<std::string, int64_t>* counters,
              std::vector<double>* edge_late_ms, Health* h, std::string* message);

 private:
  std::unique_ptr<GpioLines> chip_;
  TriggerLog& pulses_;
  TriggerPulser pulser_;
  TriggerLineHealth health_;
};

}  // namespace ptz::driver
