#include "common/transport/transport.hpp"

#include "common/freshness.hpp"

#include <malloc.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <poll.h>
#include <systemd/sd-daemon.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <thread>
#include <tuple>

namespace ptz {

void addTransportParams(Params& params) {
  params.add("lcm_url", "",
             "LCM URL; empty: $LCM_DEFAULT_URL, else udpm://239.255.76.67:7667?ttl=0&recv_buf_size="
             "4194304");
  params.add("channel_prefix", "", "prefix of every channel name (e.g. SIM_)");
  params.add("status_period_s", 1.0, "s", "period of the PROCESS_STATUS heartbeat",
             Range::between(0.01, 60));
}

std::string lcmUrl(const Params& params) {
  std::string url = params.getString("lcm_url");
  if (!url.empty()) return url;
  const char* env = std::getenv("LCM_DEFAULT_URL");
  if (env && *env) return env;
  return kDefaultLcmUrl;
}

bool warnIfReceiveBufferSmall(const std::string& url) {
  if (url.rfind("udpm://", 0) != 0) return true;
  constexpr long kNeeded = 4194304;
  long wanted = 0;
  const auto pos = url.find("recv_buf_size=");
  if (pos != std::string::npos) wanted = std::strtol(url.c_str() + pos + 14, nullptr, 10);
  long rmem_max = -1;
  if (FILE* f = std::fopen("/proc/sys/net/core/rmem_max", "r")) {
    if (std::fscanf(f, "%ld", &rmem_max) != 1) rmem_max = -1;
    std::fclose(f);
  }
  bool ok = true;
  if (wanted < kNeeded) {
    std::fprintf(stderr,
                 "warning: LCM URL '%s' asks for a receive buffer below %ld bytes: raw VGA stereo "
                 "frames will be lost. Add recv_buf_size=%ld to the URL.\n",
                 url.c_str(), kNeeded, kNeeded);
    ok = false;
  }
  if (rmem_max >= 0 && rmem_max < std::max(wanted, kNeeded)) {
    std::fprintf(stderr,
                 "warning: net.core.rmem_max is %ld, below %ld: the kernel caps the LCM receive "
                 "buffer and raw stereo frames are lost. Fix: sudo sysctl -w "
                 "net.core.rmem_max=%ld\n",
                 rmem_max, std::max(wanted, kNeeded), std::max(wanted, kNeeded));
    ok = false;
  }
  return ok;
}

void addFrameOutputParams(Params& params) {
  params.add("frame_lcm_url", "",
             "LCM URL of the bulky data this process publishes (frames, clouds); empty: lcm_url. "
             "Several hosts: lcm_url's group and port with ttl=0 keeps them on this host");
}

FrameOutput::FrameOutput(const Params& params, lcm::LCM& lcm)
    : shared_(&lcm), url_(params.getString("frame_lcm_url")) {
  if (url_.empty() || url_ == lcmUrl(params)) {
    url_ = lcmUrl(params);
    return;
  }
  own_ = std::make_unique<lcm::LCM>(url_);
  if (!own_->good()) {
    throw params.invalid("frame_lcm_url", "LCM cannot open '" + url_ + "'");
  }
}

void addPreviewParams(Params& params) {
  params.add("preview_rate_hz", 0.0, "Hz",
             "rate of STEREO_PREVIEW, small JPEG copies of the frames for a monitoring host "
             "(0: none)",
             Range::between(0, 1000));
  params.add("preview_width_px", 320, "px", "width of each preview image (height to scale)",
             Range::between(16, 4096));
  params.add("preview_jpeg_quality", 60, "", "JPEG quality of the previews",
             Range::between(1, 100));
  params.add("preview_max_bytes", 60000, "bytes",
             "a larger preview is not sent (one LCM datagram holds about 64 kB)",
             Range::between(1000, kLcmLargestDatagramBytes));
}

PreviewOutput::PreviewOutput(const Params& params)
    : schedule_(params.getDouble("preview_rate_hz")),
      width_px_(params.getInt("preview_width_px")),
      jpeg_quality_(params.getInt("preview_jpeg_quality")),
      max_bytes_(params.getInt("preview_max_bytes")),
      channel_(channel(params, channels::kStereoPreview)) {}

void PreviewOutput::maybePublish(StatusReporter& status, lcm::LCM& lcm, int64_t utime, int64_t seq,
                                 const cv::Mat& left, const PtzPose& left_pose,
                                 const cv::Mat& right, const PtzPose& right_pose,
                                 bool utime_is_wall_clock) {
  if (left.empty() || right.empty() || !schedule_.take(utime)) return;
  const auto scaled = [&](const cv::Mat& image) {
    const int width_px = std::min(width_px_, image.cols);  // smaller, never larger
    const int height_px = std::max(
        1, static_cast<int>(std::lround(static_cast<double>(width_px) * image.rows / image.cols)));
    cv::Mat small;
    cv::resize(image, small, cv::Size(width_px, height_px), 0, 0, cv::INTER_AREA);
    return small;
  };
  ptzstereo::stereo_frame_t msg =
      makeStereoFrame(utime, seq, scaled(left), left_pose, scaled(right), right_pose,
                      ptzstereo::image_t::ENCODING_JPEG, jpeg_quality_);
  if (msg.getEncodedSize() > max_bytes_) {
    status.increment("previews_too_large");
    return;
  }
  msg.publish_utime = wallUtime();
  status.publishOn(lcm, channel_, msg,
                   utime_is_wall_clock ? (msg.publish_utime - utime) / 1000.0 : -1);
}

std::string channel(const Params& params, const std::string& base) {
  return params.getString("channel_prefix") + base;
}

ptzstereo::image_t encodeImage(const cv::Mat& image, int8_t encoding, int jpeg_quality) {
  CV_Assert(image.depth() == CV_8U && (image.channels() == 1 || image.channels() == 3));
  ptzstereo::image_t msg{};
  msg.width = image.cols;
  msg.height = image.rows;
  msg.pixel_format =
      image.channels() == 3 ? ptzstereo::image_t::PIXEL_BGR8 : ptzstereo::image_t::PIXEL_GRAY8;
  msg.row_stride = image.cols * image.channels();
  msg.encoding = encoding;
  msg.zoom = 1.0;
  if (encoding == ptzstereo::image_t::ENCODING_JPEG) {
    // Restarts that split every MCU row (4:2:0: 16 px; gray 8) evenly into segments of 4 to 8
    // MCUs (a whole row when none divides it): a window decodes from its own rows' and columns'
    // segments alone (jpeg_restart.hpp).
    const int mcus_per_row = image.channels() == 3 ? (image.cols + 15) / 16 : (image.cols + 7) / 8;
    int interval = mcus_per_row;
    for (int mcus = 8; mcus >= 4 && interval == mcus_per_row; --mcus) {
      if (mcus < mcus_per_row && mcus_per_row % mcus == 0) interval = mcus;
    }
    cv::imencode(".jpg", image, msg.data,
                 {cv::IMWRITE_JPEG_QUALITY, jpeg_quality, cv::IMWRITE_JPEG_RST_INTERVAL, interval});
  } else {
    msg.data.resize(static_cast<size_t>(msg.row_stride) * image.rows);
    for (int r = 0; r < image.rows; ++r) {
      std::copy(image.ptr<uint8_t>(r), image.ptr<uint8_t>(r) + msg.row_stride,
                msg.data.begin() + static_cast<ptrdiff_t>(r) * msg.row_stride);
    }
  }
  msg.data_size = static_cast<int32_t>(msg.data.size());
  return msg;
}

ptzstereo::image_t encodeImage(const cv::Mat& image, const PtzPose& pose, int8_t encoding,
                               int jpeg_quality) {
  ptzstereo::image_t msg = encodeImage(image, encoding, jpeg_quality);
  msg.pan_rad = pose.pan_rad;
  msg.tilt_rad = pose.tilt_rad;
  msg.zoom = pose.zoom;
  return msg;
}

ptzstereo::stereo_frame_t makeStereoFrame(int64_t utime, int64_t seq, const cv::Mat& left,
                                          const PtzPose& left_pose, const cv::Mat& right,
                                          const PtzPose& right_pose, int8_t encoding,
                                          int jpeg_quality) {
  ptzstereo::stereo_frame_t msg{};
  msg.utime = utime;
  msg.seq = seq;
  // The two images on two cores: JPEG encoding is most of a frame's readout after the render.
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& sides) {
    for (int side = sides.start; side < sides.end; ++side) {
      if (side == 0) msg.left = encodeImage(left, left_pose, encoding, jpeg_quality);
      if (side == 1) msg.right = encodeImage(right, right_pose, encoding, jpeg_quality);
    }
  });
  return msg;
}

void addImageEncodingParams(Params& params) {
  params.add("encoding", "raw", "image encoding in STEREO_FRAME: raw or jpeg");
  params.add("jpeg_quality", 90, "", "JPEG quality", Range::between(1, 100));
}

int8_t imageEncodingFrom(const Params& params) {
  const std::string enc = params.getString("encoding");
  if (enc != "raw" && enc != "jpeg") {
    throw ConfigError("parameter 'encoding' must be raw or jpeg, got '" + enc + "'");
  }
  const int quality = params.getInt("jpeg_quality");
  if (quality < 1 || quality > 100) {
    throw ConfigError("parameter 'jpeg_quality' must be 1..100, got " + std::to_string(quality));
  }
  return enc == "jpeg" ? ptzstereo::image_t::ENCODING_JPEG : ptzstereo::image_t::ENCODING_RAW;
}

void keepFreedMemory() {
  // Frame-sized buffers come and go every frame. By default glibc maps each above its threshold
  // afresh and trims the heap after it, so every frame page-faults its buffers in again: a third
  // of ptz-detect's time on a VM (ptz_bench_loop). Kept, they are reused.
  // glibc's largest threshold: 4 MiB * sizeof(long) (32 MiB on 64-bit, 16 MiB on 32-bit).
  const int threshold = static_cast<int>((4 << 20) * sizeof(long));
  if (mallopt(M_MMAP_THRESHOLD, threshold) != 1 || mallopt(M_TRIM_THRESHOLD, 512 << 20) != 1) {
    std::fprintf(stderr, "warning: freed memory is not kept for reuse (mallopt refused)\n");
  }
}

int runProcess(int argc, char** argv, Params& params,
               const std::function<int(const Params&, lcm::LCM&)>& body) {
  const char* name = params.program().c_str();
  keepFreedMemory();
  try {
    if (!params.parse(argc, argv)) return 0;
    const std::string url = lcmUrl(params);
    warnIfReceiveBufferSmall(url);
    lcm::LCM lcm(url);
    if (!lcm.good()) {
      std::fprintf(stderr,
                   "%s: cannot open LCM at '%s' (multicast route? scripts/check-network "
                   "says)\n",
                   name, url.c_str());
      return 1;
    }
    StopFlag::install();
    return body(params, lcm);
  } catch (const ConfigError& e) {
    std::fprintf(stderr, "%s: %s\n", name, e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: stopped: %s\n", name, e.what());
    return 3;
  }
}

namespace {
std::atomic<bool> g_stop{false};
void onSignal(int) {
  g_stop = true;
}
}  // namespace

void StopFlag::install() {
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}
bool StopFlag::stopRequested() {
  return g_stop.load();
}
void StopFlag::request() {
  g_stop = true;
}

StatusReporter::StatusReporter(lcm::LCM* lcm, const Params& params, const std::string& process)
    : lcm_(lcm),
      process_(process),
      period_s_(params.getDouble("status_period_s")),
      start_utime_(wallUtime()),
      last_publish_utime_(start_utime_) {
  std::string upper;
  for (char c : process) upper += c == '-' ? '_' : static_cast<char>(std::toupper(c));
  channel_ = channel(params, std::string(channels::kProcessStatusPrefix) + upper);
  char host[256] = {};
  gethostname(host, sizeof(host) - 1);
  hostname_ = host;
}

StatusReporter::ChannelStats& StatusReporter::stats(const std::string& ch, int8_t direction) {
  auto& s = channels_[ch + (direction ? ">" : "<")];
  s.direction = direction;
  return s;
}

void StatusReporter::countIn(const std::string& ch, double latency_ms) {
  auto& s = stats(ch, ptzstereo::channel_status_t::DIRECTION_IN);
  ++s.messages;
  if (auto it = expected_.find(ch); it != expected_.end()) it->second.last_utime = clock_();
  if (latency_ms >= 0 && s.latencies_ms.size() < 100000) s.latencies_ms.push_back(latency_ms);
}

void StatusReporter::countOut(const std::string& ch, double latency_ms) {
  auto& s = stats(ch, ptzstereo::channel_status_t::DIRECTION_OUT);
  ++s.messages;
  if (latency_ms >= 0 && s.latencies_ms.size() < 100000) s.latencies_ms.push_back(latency_ms);
}

void StatusReporter::countDropped(const std::string& ch, const std::string& reason, int64_t n) {
  stats(ch, ptzstereo::channel_status_t::DIRECTION_IN).dropped += n;
  increment("dropped_" + reason, n);
  increment(ch + ".dropped_" + reason, n);
}

void StatusReporter::expectInput(const std::string& ch, double warn_after_s, double error_after_s) {
  expected_[ch] = {warn_after_s, error_after_s, clock_()};
}

void StatusReporter::publishFailed(const std::string& ch) {
  const int error = errno;
  last_publish_failure_utime_ = clock_();
  last_publish_failure_ = ch + ": " + (error ? std::strerror(error) : "LCM refused the message");
  increment("publish_failures");
  increment(ch + ".publish_failures");
  log_.warn("publish " + ch, process_ + ": cannot publish " + last_publish_failure_ +
                                 " (multicast route? scripts/check-network says)");
}

std::pair<int8_t, std::string> StatusReporter::health() const {
  using S = ptzstereo::process_status_t;
  const int64_t now = clock_();
  int8_t state = state_;
  std::string message = message_;
  auto add = [&](int8_t s, const std::string& m) {
    state = std::max(state, s);
    message += (message.empty() ? "" : "; ") + m;
  };
  for (const auto& [ch, e] : expected_) {
    const double silent_s = (now - e.last_utime) * 1e-6;
    if (silent_s >= e.error_after_s) {
      add(S::STATE_ERROR, "no " + ch + " for " + formatNumber(std::floor(silent_s)) + " s");
    } else if (silent_s >= e.warn_after_s) {
      add(S::STATE_WARN, "no " + ch + " for " + formatNumber(std::floor(silent_s)) + " s");
    }
  }
  if (last_publish_failure_utime_ != 0 &&
      now - last_publish_failure_utime_ < static_cast<int64_t>(kPublishErrorHoldS * 1e6)) {
    add(S::STATE_ERROR, "cannot publish " + last_publish_failure_);
  }
  return {state, message};
}

void StatusReporter::feedWatchdog(int64_t now_utime) {
  if (now_utime - last_watchdog_utime_ < 200'000) return;
  last_watchdog_utime_ = now_utime;
  sd_notify(0, "WATCHDOG=1");
}

void StatusReporter::increment(const std::string& name, int64_t by) {
  counters_[name] += by;
}
void StatusReporter::setCounter(const std::string& name, int64_t value) {
  counters_[name] = value;
}
void StatusReporter::setPercentilesUs(const std::string& name, std::vector<double>* samples_ms,
                                      size_t min_samples) {
  if (samples_ms->size() < min_samples) return;
  counters_[name + "_us_p50"] = std::llround(percentile(*samples_ms, 50) * 1000);
  counters_[name + "_us_p99"] = std::llround(percentile(*samples_ms, 99) * 1000);
  samples_ms->clear();
}
int64_t StatusReporter::counter(const std::string& name) const {
  auto it = counters_.find(name);
  return it == counters_.end() ? 0 : it->second;
}

void StatusReporter::setState(int8_t state, const std::string& message) {
  state_ = state;
  message_ = message;
}

bool StatusReporter::maybePublish() {
  feedWatchdog(clock_());
  if (clock_() - last_publish_utime_ < static_cast<int64_t>(period_s_ * 1e6)) return false;
  publishNow();
  return true;
}

namespace {
const char* stateName(int8_t state) {
  using S = ptzstereo::process_status_t;
  return state == S::STATE_OK ? "OK" : state == S::STATE_WARN ? "WARN" : "ERROR";
}
}  // namespace

void StatusReporter::publishNow() {
  send(1);
}

void StatusReporter::publishLast() {
  send(kLastStatusCopies);
}

void StatusReporter::send(int copies) {
  const int64_t now = clock_();
  const double period_s = std::max(1e-6, (now - last_publish_utime_) * 1e-6);
  ptzstereo::process_status_t msg{};
  msg.utime = now;
  msg.process = process_;
  msg.hostname = hostname_;
  msg.pid = static_cast<int32_t>(getpid());
  msg.uptime_s = (now - start_utime_) * 1e-6;
  std::tie(msg.state, msg.message) = health();
  for (auto& [key, s] : channels_) {
    ptzstereo::channel_status_t c{};
    c.channel = key.substr(0, key.size() - 1);
    c.direction = s.direction;
    c.rate_hz = (s.messages - s.messages_at_last_publish) / period_s;
    c.messages = s.messages;
    c.dropped = s.dropped;
    c.latency_ms_p50 = percentile(s.latencies_ms, 50);
    c.latency_ms_p99 = percentile(s.latencies_ms, 99);
    s.latencies_ms.clear();
    s.messages_at_last_publish = s.messages;
    msg.channels.push_back(c);
  }
  msg.num_channels = static_cast<int32_t>(msg.channels.size());
  for (const auto& [name, value] : counters_) msg.counters.push_back({name, value});
  msg.num_counters = static_cast<int32_t>(msg.counters.size());
  for (int i = 0; i < copies; ++i) {
    // Copies apart in time, so that a burst of loss takes at most one.
    if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (lcm_->publish(channel_, &msg) != 0) publishFailed(channel_);
  }
  if (msg.state != said_state_) {  // a change of health goes to stderr too (journals, scripts)
    std::fprintf(stderr, "%s: %s%s%s\n", process_.c_str(), stateName(msg.state),
                 msg.message.empty() ? "" : ": ", msg.message.c_str());
    said_state_ = msg.state;
  }
  last_publish_utime_ = now;
  if (!announced_) {
    announced_ = true;
    sd_notify(0, "READY=1");
  }
  feedWatchdog(now);
}

bool messageWaiting(lcm::LCM& lcm) {
  pollfd fd{lcm.getFileno(), POLLIN, 0};
  return ::poll(&fd, 1, 0) > 0 && (fd.revents & POLLIN);
}

namespace {
std::map<lcm::LCM*, std::vector<PendingDelivery*>>& pendingRegistry() {
  static std::map<lcm::LCM*, std::vector<PendingDelivery*>> registry;
  return registry;
}
}  // namespace

void registerPending(lcm::LCM* lcm, PendingDelivery* sub) {
  pendingRegistry()[lcm].push_back(sub);
}

void unregisterPending(lcm::LCM* lcm, PendingDelivery* sub) {
  auto& subs = pendingRegistry()[lcm];
  subs.erase(std::remove(subs.begin(), subs.end(), sub), subs.end());
  if (subs.empty()) pendingRegistry().erase(lcm);
}

int handleNewest(lcm::LCM& lcm, int timeout_ms, int max_drain) {
  const int handled = lcm.handleTimeout(timeout_ms);
  if (handled <= 0) return handled;
  for (int i = 0; i < max_drain && messageWaiting(lcm); ++i) {
    if (lcm.handleTimeout(0) <= 0) break;
  }
  auto it = pendingRegistry().find(&lcm);
  if (it == pendingRegistry().end()) return handled;
  const std::vector<PendingDelivery*> subs = it->second;  // a handler may subscribe
  for (PendingDelivery* sub : subs) sub->deliver();
  return handled;
}

void SequenceCounter::chargeGap(StatusReporter& status, const std::string& channel, int64_t missing,
                                bool own_sequence) {
  if (missing <= 0) return;
  if (own_sequence) {
    status.countDropped(channel, "seq_gap", missing);
  } else {
    status.increment(channel + ".seq_gap", missing);
  }
}

void SequenceCounter::count(StatusReporter& status, const std::string& channel, int64_t seq,
                            bool own_sequence) {
  if (seq < 0) return;
  if (last_seq_ < 0) {
    last_seq_ = seq;
    return;
  }
  if (jump_seq_ >= 0) {
    const int64_t after_jump = saturatingDiffUs(seq, jump_seq_);
    if (after_jump > 0 && after_jump <= kMaxGap) {  // it goes on from the jump: it was real
      const int64_t missing = jump_seq_ - last_seq_ - 1;
      if (missing < kMaxGap) {
        chargeGap(status, channel, missing, own_sequence);
      } else {
        status.increment(channel + ".seq_restart");  // a new source, not lost frames
      }
      last_seq_ = jump_seq_;
    } else {
      status.increment(channel + ".seq_outlier");
    }
    jump_seq_ = -1;
  }
  const int64_t step = saturatingDiffUs(seq, last_seq_);
  if (step == 1) {
    last_seq_ = seq;
  } else if (step > 1) {
    jump_seq_ = seq;
  } else {
    status.increment(channel + ".seq_restart");
    last_seq_ = seq;
  }
}

int serveUntilStopped(lcm::LCM& lcm, StatusReporter& status) {
  status.publishNow();
  while (!StopFlag::stopRequested()) {
    handleNewest(lcm, 100);
    status.maybePublish();
  }
  status.publishLast();
  return 0;
}

void RateLimitedLog::warn(const std::string& key, const std::string& message) {
  const int64_t now = wallUtime();
  auto it = last_.find(key);
  if (it != last_.end() && now - it->second.first < static_cast<int64_t>(period_s_ * 1e6)) {
    ++it->second.second;
    return;
  }
  const int64_t suppressed = it == last_.end() ? 0 : it->second.second;
  if (suppressed > 0) {
    std::fprintf(stderr, "warning: %s (%lld more like it since the last warning)\n",
                 message.c_str(), static_cast<long long>(suppressed));
  } else {
    std::fprintf(stderr, "warning: %s\n", message.c_str());
  }
  last_[key] = {now, 0};
}

}  // namespace ptz
