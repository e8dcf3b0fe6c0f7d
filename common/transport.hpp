// The LCM edge shared by every process: URL and channel names, image encoding inside
// STEREO_FRAME, the 1 Hz PROCESS_STATUS heartbeat, clocks and clean shutdown.
#pragma once

#include <lcm/lcm-cpp.hpp>
#include <opencv2/core.hpp>

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "common/measure.hpp"  // wallUtime, percentile (re-exported)
#include "common/rig.hpp"
#include "ptzstereo/image_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz {

// Host-only multicast with a receive buffer that holds raw VGA stereo frames.
constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";

// Declares lcm_url, channel_prefix and status_period_s.
void addTransportParams(Params& params);
// --lcm-url, else $LCM_DEFAULT_URL, else kDefaultLcmUrl.
std::string lcmUrl(const Params& params);
// Warns on stderr (with the exact fix) when a udpm URL asks for no receive buffer or for one
// larger than net.core.rmem_max allows: raw VGA stereo frames are then lost. Returns false then.
bool warnIfReceiveBufferSmall(const std::string& url);
// Channel name with the configured prefix (lets a simulated and a real rig share a network).
std::string channel(const Params& params, const std::string& base);

// Channel names of the message contract (DESIGN.md).
namespace channels {
constexpr const char* kStereoFrame = "STEREO_FRAME";
constexpr const char* kPtzState = "PTZ_STATE";
constexpr const char* kPtzSetpoint = "PTZ_SETPOINT";
constexpr const char* kSimTruth = "SIM_TRUTH";
constexpr const char* kObjectDetections = "OBJECT_DETECTIONS";
constexpr const char* kObjectPose = "OBJECT_POSE";
constexpr const char* kPointCloud = "POINT_CLOUD";
constexpr const char* kDisparityImage = "DISPARITY_IMAGE";
constexpr const char* kProcessStatusPrefix = "PROCESS_STATUS_";
}  // namespace channels

// Encodes an 8-bit BGR or gray image. jpeg_quality is used for ENCODING_JPEG only.
ptzstereo::image_t encodeImage(const cv::Mat& image, int8_t encoding, int jpeg_quality);
// The same, with the camera's pan/tilt/zoom at capture.
ptzstereo::image_t encodeImage(const cv::Mat& image, const PtzPose& pose, int8_t encoding,
                               int jpeg_quality);
// A STEREO_FRAME as every frame source publishes it (ptz-sim, ptz-camera); publish_utime is
// left to the publisher.
ptzstereo::stereo_frame_t makeStereoFrame(int64_t utime, int64_t seq, const cv::Mat& left,
                                          const PtzPose& left_pose, const cv::Mat& right,
                                          const PtzPose& right_pose, int8_t encoding,
                                          int jpeg_quality);
// Declares `encoding` (raw or jpeg) and `jpeg_quality` of the images in STEREO_FRAME.
void addImageEncodingParams(Params& params);
// image_t::ENCODING_RAW or ENCODING_JPEG; throws ConfigError for another name or quality.
int8_t imageEncodingFrom(const Params& params);
// Decodes to BGR8 (or GRAY8). Returns false and says why for anything inconsistent.
bool decodeImage(const ptzstereo::image_t& msg, cv::Mat* image, std::string* error);

// The main of every process: parses flags and the config file (--help prints the usage), opens
// LCM at lcmUrl() (warning when its receive buffer is too small), installs the stop flag and
// runs body. A ConfigError from any of it ends the process with exit code 2 and the message
// (file and field named); an LCM that cannot open, with 1.
int runProcess(int argc, char** argv, Params& params,
               const std::function<int(const Params&, lcm::LCM&)>& body);

// Set by SIGINT/SIGTERM; processes poll it in their loop.
class StopFlag {
 public:
  static void install();
  static bool stopRequested();
  static void request();
};

// Rates, latencies, drops and counters of one process, published at 1 Hz.
class StatusReporter {
 public:
  StatusReporter(lcm::LCM* lcm, const Params& params, const std::string& process);

  // latency_ms < 0: unknown.
  void countIn(const std::string& channel, double latency_ms);
  void countOut(const std::string& channel, double latency_ms);
  void countDropped(const std::string& channel, const std::string& reason);
  void increment(const std::string& counter, int64_t by = 1);
  void setCounter(const std::string& counter, int64_t value);
  // Once samples_ms holds at least min_samples: counters NAME_us_p50 and NAME_us_p99 (in
  // microseconds), and the samples start over.
  void setPercentilesUs(const std::string& name, std::vector<double>* samples_ms,
                        size_t min_samples);
  int64_t counter(const std::string& name) const;
  void setState(int8_t state, const std::string& message);
  // Publishes when a period has passed; returns true when it did.
  bool maybePublish();
  void publishNow();
  const std::string& channelName() const { return channel_; }

 private:
  struct ChannelStats {
    int8_t direction = 0;
    int64_t messages = 0;
    int64_t dropped = 0;
    int64_t messages_at_last_publish = 0;
    std::vector<double> latencies_ms;
  };
  ChannelStats& stats(const std::string& channel, int8_t direction);

  lcm::LCM* lcm_;
  std::string process_;
  std::string channel_;
  std::string hostname_;
  double period_s_;
  int64_t start_utime_;
  int64_t last_publish_utime_;
  int8_t state_ = ptzstereo::process_status_t::STATE_OK;
  std::string message_;
  std::map<std::string, ChannelStats> channels_;
  std::map<std::string, int64_t> counters_;
};

// The loop of a process driven by its input: announces itself ("up and subscribed": tests and
// scripts wait for that status), handles messages until SIGINT/SIGTERM, publishes a last status.
int serveUntilStopped(lcm::LCM& lcm, StatusReporter& status);

// A subscription whose decoding cannot take the process down: lcm-gen's decoders size arrays
// from the sender's counts before checking the buffer, so a malformed message can throw. Such a
// message is dropped and counted (dropped_undecodable); the handler sees only whole messages.
template <class Msg>
class SafeSubscription {
 public:
  using Handler = std::function<void(const std::string& channel, const Msg& msg)>;
  SafeSubscription(lcm::LCM& lcm, const std::string& channel, StatusReporter& status,
                   Handler handler, int queue_capacity = 0)
      : status_(status), handler_(std::move(handler)) {
    lcm::Subscription* sub = lcm.subscribeFunction(channel, &SafeSubscription::dispatch, this);
    if (queue_capacity > 0) sub->setQueueCapacity(queue_capacity);
  }
  SafeSubscription(const SafeSubscription&) = delete;
  SafeSubscription& operator=(const SafeSubscription&) = delete;

 private:
  static void dispatch(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                       SafeSubscription* self) {
    Msg msg;
    bool ok = false;
    try {
      ok = msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) >= 0;
    } catch (const std::exception&) {
      ok = false;
    }
    if (!ok) {
      self->status_.countDropped(channel, "undecodable");
      return;
    }
    self->handler_(channel, msg);
  }

  StatusReporter& status_;
  Handler handler_;
};

// Warns on stderr at most once per period per key, with the count since the last warning.
class RateLimitedLog {
 public:
  explicit RateLimitedLog(double period_s = 5.0) : period_s_(period_s) {}
  void warn(const std::string& key, const std::string& message);

 private:
  double period_s_;
  std::map<std::string, std::pair<int64_t, int64_t>> last_;  // key -> (utime, suppressed)
};

}  // namespace ptz
