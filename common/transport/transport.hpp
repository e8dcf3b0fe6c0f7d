// The LCM edge shared by every process: URL and channel names, image encoding inside
// STEREO_FRAME, the 1 Hz PROCESS_STATUS heartbeat, clocks and clean shutdown.
#pragma once

#include <lcm/lcm-cpp.hpp>
#include <opencv2/core.hpp>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "common/config.hpp"
#include "common/measure.hpp"  // wallUtime, percentile (re-exported)
#include "common/rig.hpp"
#include "common/transport/message_check.hpp"
#include "ptzstereo/image_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"

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
// Declares frame_lcm_url, for the processes that publish bulky data (frames, clouds).
void addFrameOutputParams(Params& params);

// Where a process publishes its bulky data (STEREO_FRAME, POINT_CLOUD, DISPARITY_IMAGE): a second
// LCM at frame_lcm_url, else the process's own. On a LAN the same group and port at ttl=0 keeps
// them on this host, where its own consumers hear them, while the rest crosses at ttl=1: one lost
// IP fragment loses a whole frame (DESIGN.md, Several hosts). Throws ConfigError when it cannot
// open.
class FrameOutput {
 public:
  FrameOutput(const Params& params, lcm::LCM& lcm);
  lcm::LCM& lcm() { return own_ ? *own_ : *shared_; }
  const std::string& url() const { return url_; }

 private:
  lcm::LCM* shared_;
  std::unique_ptr<lcm::LCM> own_;
  std::string url_;
};

class StatusReporter;

// Declares preview_rate_hz, preview_width_px, preview_jpeg_quality and preview_max_bytes.
void addPreviewParams(Params& params);

// Small JPEG copies of the frames on STEREO_PREVIEW (the same type), for a monitoring host when
// the frames themselves stay on the host that makes them: bounded in rate and in bytes, so that
// one fits one datagram (DESIGN.md, Several hosts).
class PreviewOutput {
 public:
  explicit PreviewOutput(const Params& params);
  bool enabled() const { return schedule_.enabled(); }
  // When one is due by capture time: both images scaled down to preview_width_px, published on
  // lcm. One over preview_max_bytes is not sent (previews_too_large). The latency is counted only
  // where utime is wall-clock time (not in lockstep).
  void maybePublish(StatusReporter& status, lcm::LCM& lcm, int64_t utime, int64_t seq,
                    const cv::Mat& left, const PtzPose& left_pose, const cv::Mat& right,
                    const PtzPose& right_pose, bool utime_is_wall_clock = true);

 private:
  RateSchedule schedule_;
  int width_px_;
  int jpeg_quality_;
  int64_t max_bytes_;
  std::string channel_;
};

// Channel name with the configured prefix (lets a simulated and a real rig share a network).
std::string channel(const Params& params, const std::string& base);

// Channel names of the message contract (DESIGN.md).
namespace channels {
constexpr const char* kStereoFrame = "STEREO_FRAME";
constexpr const char* kStereoPreview = "STEREO_PREVIEW";
constexpr const char* kPtzState = "PTZ_STATE";
constexpr const char* kPtzSetpoint = "PTZ_SETPOINT";
constexpr const char* kSimTruth = "SIM_TRUTH";
constexpr const char* kObjectDetections = "OBJECT_DETECTIONS";
constexpr const char* kObjectPose = "OBJECT_POSE";
constexpr const char* kObjectTracks = "OBJECT_TRACKS";
constexpr const char* kTargetSelect = "TARGET_SELECT";
constexpr const char* kControlState = "CONTROL_STATE";
constexpr const char* kPointCloud = "POINT_CLOUD";
constexpr const char* kPointCloudPreview = "POINT_CLOUD_PREVIEW";
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

// Keeps freed memory in the process for reuse (no unmapping or trimming of the heap): frames'
// buffers are not page-faulted in again every frame. runProcess does it first.
void keepFreedMemory();

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

// LCM 1.3.1 returns 0 for a message it sends in fragments (one over this size: every frame) even
// when the sends failed (no route: a link went down); the errno they leave says so, and nothing
// else on that path sets it.
constexpr int kLcmLargestDatagramBytes = 65'000;

// Warns on stderr at most once per period per key, with the count since the last warning.
class RateLimitedLog {
 public:
  explicit RateLimitedLog(double period_s = 5.0) : period_s_(period_s) {}
  void warn(const std::string& key, const std::string& message);

 private:
  double period_s_;
  std::map<std::string, std::pair<int64_t, int64_t>> last_;  // key -> (utime, suppressed)
};

// Rates, latencies, drops, counters and health of one process, published at 1 Hz. The state it
// publishes is the worst of the process's own (setState), its driving inputs' (WARN when one has
// been absent for warn_after_s, ERROR after error_after_s) and its publishing (ERROR for
// kPublishErrorHoldS after a publish failed). It also feeds the service manager's watchdog
// (sd_notify: READY=1 on the first status, WATCHDOG=1 from the loop), a no-op outside systemd.
class StatusReporter {
 public:
  StatusReporter(lcm::LCM* lcm, const Params& params, const std::string& process);

  // latency_ms < 0: unknown.
  void countIn(const std::string& channel, double latency_ms);
  void countOut(const std::string& channel, double latency_ms);
  // A message dropped for reason: counted on its channel, in dropped_REASON and in
  // CHANNEL.dropped_REASON.
  void countDropped(const std::string& channel, const std::string& reason, int64_t n = 1);
  void increment(const std::string& counter, int64_t by = 1);
  void setCounter(const std::string& counter, int64_t value);
  // Every (name, value) of counters: what a process's library reports after each message.
  template <class Counters>
  void setCounters(const Counters& counters) {
    for (const auto& [name, value] : counters) setCounter(name, value);
  }
  // Once samples_ms holds at least min_samples: counters NAME_us_p50 and NAME_us_p99 (in
  // microseconds), and the samples start over.
  void setPercentilesUs(const std::string& name, std::vector<double>* samples_ms,
                        size_t min_samples);
  int64_t counter(const std::string& name) const;
  void setState(int8_t state, const std::string& message);
  // A channel whose silence means the process is starving (its countIn is the sign of life).
  void expectInput(const std::string& channel, double warn_after_s = 1.0,
                   double error_after_s = 5.0);
  // Publishes and counts msg on channel; on failure ERROR, publish_failures and a warning on
  // stderr naming the channel and the error. Returns whether LCM took it.
  template <class Msg>
  bool publish(const std::string& channel, const Msg& msg, double latency_ms = -1) {
    return publishOn(*lcm_, channel, msg, latency_ms);
  }
  // The same on another LCM (a FrameOutput's).
  template <class Msg>
  bool publishOn(lcm::LCM& lcm, const std::string& channel, const Msg& msg,
                 double latency_ms = -1) {
    errno = 0;
    if (lcm.publish(channel, &msg) != 0 ||
        (msg.getEncodedSize() > kLcmLargestDatagramBytes && errno != 0)) {
      publishFailed(channel);
      return false;
    }
    countOut(channel, latency_ms);
    return true;
  }
  // Publishes when a period has passed; returns true when it did. Feeds the watchdog.
  bool maybePublish();
  void publishNow();
  // The last status of a process that stops, sent kLastStatusCopies times: over a lossy link its
  // final counters (frames published, ...) still arrive.
  void publishLast();
  const std::string& channelName() const { return channel_; }
  const std::string& process() const { return process_; }
  // The state and message publishNow would send now.
  std::pair<int8_t, std::string> health() const;
  // The clock of the health rules (tests inject one); wallUtime by default.
  void useClock(std::function<int64_t()> clock) { clock_ = std::move(clock); }

  static constexpr double kPublishErrorHoldS = 5.0;
  static constexpr int kLastStatusCopies = 3;

 private:
  struct ChannelStats {
    int8_t direction = 0;
    int64_t messages = 0;
    int64_t dropped = 0;
    int64_t messages_at_last_publish = 0;
    std::vector<double> latencies_ms;
  };
  struct Expected {
    double warn_after_s;
    double error_after_s;
    int64_t last_utime;
  };
  ChannelStats& stats(const std::string& channel, int8_t direction);
  void publishFailed(const std::string& channel);
  void send(int copies);
  void feedWatchdog(int64_t now_utime);

  lcm::LCM* lcm_;
  std::string process_;
  std::string channel_;
  std::string hostname_;
  double period_s_;
  int64_t start_utime_;
  int64_t last_publish_utime_;
  int64_t last_publish_failure_utime_ = 0;
  std::string last_publish_failure_;
  int64_t last_watchdog_utime_ = 0;
  bool announced_ = false;
  int8_t state_ = ptzstereo::process_status_t::STATE_OK;
  int8_t said_state_ = ptzstereo::process_status_t::STATE_OK;  // the last state on stderr
  std::string message_;
  std::map<std::string, ChannelStats> channels_;
  std::map<std::string, Expected> expected_;
  std::map<std::string, int64_t> counters_;
  RateLimitedLog log_;
  std::function<int64_t()> clock_ = wallUtime;
};

// How a subscription hands messages to its handler: every one in order as it is handled, or only
// the newest of those waiting, once handleNewest() has drained them (a consumer of frames or poses
// must never work through a backlog; those passed over are counted dropped_superseded).
enum class Delivery { kEvery, kNewest };

// Frame sequence number of a message, -1 where it has none (gaps in it are counted seq_gap).
namespace detail {
template <class Msg>
auto frameSeq(const Msg& m, int) -> decltype(int64_t{m.frame_seq}) {
  return m.frame_seq;
}
template <class Msg>
int64_t frameSeq(const Msg&, long) {
  return -1;
}
}  // namespace detail
inline int64_t sequenceOf(const ptzstereo::stereo_frame_t& m) {
  return m.seq;
}
// A request's frame_seq names the frame pointed at, not a place in a sequence of requests.
inline int64_t sequenceOf(const ptzstereo::target_select_t&) {
  return -1;
}
template <class Msg>
int64_t sequenceOf(const Msg& m) {
  return detail::frameSeq(m, 0);
}

// Whether another message is waiting to be handled (nothing is read).
bool messageWaiting(lcm::LCM& lcm);

// A subscription holding the newest message until the loop hands it over.
class PendingDelivery {
 public:
  virtual ~PendingDelivery() = default;
  virtual void deliver() = 0;
};
void registerPending(lcm::LCM* lcm, PendingDelivery* sub);
void unregisterPending(lcm::LCM* lcm, PendingDelivery* sub);

// lcm.handleTimeout(timeout_ms), then everything else already waiting (at most max_drain
// messages), then each Delivery::kNewest subscription's newest message to its handler. Returns
// handleTimeout's result. Every loop of a process with a kNewest subscription calls this.
int handleNewest(lcm::LCM& lcm, int timeout_ms, int max_drain = 256);

// The loop of a process driven by its input: announces itself ("up and subscribed": tests and
// scripts wait for that status), handles messages (handleNewest) until SIGINT/SIGTERM, publishes a
// last status.
int serveUntilStopped(lcm::LCM& lcm, StatusReporter& status);

// Counts gaps in a channel's frame sequence. On STEREO_FRAME the seq is the channel's own: a gap
// is frames lost on the way (dropped_seq_gap, by number). On a derived channel (frame_seq of a
// pose or setpoint) a gap is frames not answered upstream or lost: CHANNEL.seq_gap, not a drop
// of this process's (upstream counts its own). A forward jump is charged only once the next
// message continues from it: a lone hostile seq is an outlier (CHANNEL.seq_outlier), not a
// million lost frames. A sequence that goes back, or goes on from a jump of kMaxGap or more (a new
// source), counts seq_restart.
class SequenceCounter {
 public:
  static constexpr int64_t kMaxGap = 100'000;
  void count(StatusReporter& status, const std::string& channel, int64_t seq, bool own_sequence);

 private:
  void chargeGap(StatusReporter& status, const std::string& channel, int64_t missing,
                 bool own_sequence);
  int64_t last_seq_ = -1;
  int64_t jump_seq_ = -1;  // a forward jump its successor has not confirmed yet
};

// A subscription whose decoding cannot take the process down or make it allocate: every message
// is checked against the bytes it came in before it is decoded (message_check.hpp); a malformed
// one is dropped and counted (dropped_undecodable, with the reason on stderr, rate-limited).
template <class Msg>
class SafeSubscription : public PendingDelivery {
 public:
  using Handler = std::function<void(const std::string& channel, const Msg& msg)>;
  SafeSubscription(lcm::LCM& lcm, const std::string& channel, StatusReporter& status,
                   Handler handler, Delivery delivery = Delivery::kEvery, int queue_capacity = 0)
      : lcm_(&lcm), status_(status), handler_(std::move(handler)), delivery_(delivery) {
    subscription_ = lcm.subscribeFunction(channel, &SafeSubscription::dispatch, this);
    // LCM's own queue: messages beyond it are lost before they are seen (seq_gap counts them).
    if (queue_capacity > 0) subscription_->setQueueCapacity(queue_capacity);
    if (delivery_ == Delivery::kNewest) registerPending(lcm_, this);
  }
  ~SafeSubscription() override {
    if (delivery_ == Delivery::kNewest) unregisterPending(lcm_, this);
    lcm_->unsubscribe(subscription_);
  }
  SafeSubscription(const SafeSubscription&) = delete;
  SafeSubscription& operator=(const SafeSubscription&) = delete;

  void deliver() override {
    if (!pending_) return;
    Msg msg = std::move(*pending_);
    pending_.reset();
    handler_(pending_channel_, msg);
  }

 private:
  static void dispatch(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                       SafeSubscription* self) {
    Msg msg;
    std::string why;
    if (!decodeChecked(rbuf->data, rbuf->data_size, &msg, &why)) {
      self->status_.countDropped(channel, "undecodable");
      self->log_.warn("undecodable " + channel,
                      self->status_.process() + ": dropped a message on " + channel + ": " + why);
      return;
    }
    self->sequence_.count(self->status_, channel, sequenceOf(msg),
                          std::is_same_v<Msg, ptzstereo::stereo_frame_t>);
    if (self->delivery_ == Delivery::kEvery) {
      self->handler_(channel, msg);
      return;
    }
    if (self->pending_) self->status_.countDropped(self->pending_channel_, "superseded");
    self->pending_ = std::move(msg);
    self->pending_channel_ = channel;
  }

  lcm::LCM* lcm_;
  lcm::Subscription* subscription_ = nullptr;
  StatusReporter& status_;
  Handler handler_;
  Delivery delivery_;
  std::optional<Msg> pending_;
  std::string pending_channel_;
  SequenceCounter sequence_;
  RateLimitedLog log_;
};

}  // namespace ptz
