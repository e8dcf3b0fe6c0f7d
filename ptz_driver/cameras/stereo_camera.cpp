#include "ptz_driver/cameras/stereo_camera.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ptz::driver {
namespace {

const std::array<const char*, 2> kSide = {"left", "right"};

bool exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

std::string joined(const std::vector<std::string>& parts) {
  std::string out;
  for (const auto& s : parts) out += (out.empty() ? "" : "; ") + s;
  return out;
}

}  // namespace

void declareCameraParams(Params& p) {
  p.add("left_source", "",
        "left camera: V4L2 index or /dev/videoN, rtsp:// URL, GStreamer pipeline ending in "
        "appsink, video file or image folder (rules in ptz_driver/cameras/README.md)");
  p.add("right_source", "", "right camera, in the same forms");
  p.add("left_timestamps", "",
        "left video/folder capture times, one per line in us (empty: SOURCE.timestamps when it "
        "exists, else frame index / rate)");
  p.add("right_timestamps", "", "right video/folder capture times (as left_timestamps)");
  p.add("loop", false, "files: play again from the start at the end, times continuing");
  p.add("file_fps", 0.0, "Hz", "rate of files without timestamps (0: the video's own; folders 30)",
        Range::between(0, 1000));
  p.add("latency_s", 0.0, "s",
        "live sources: capture time = grab time (V4L2: the driver's buffer time) minus this",
        Range::between(0, 60));
  p.add("left_latency_s", -1.0, "s", "the left camera's own latency_s (negative: latency_s)",
        Range::atMost(60));
  p.add("right_latency_s", -1.0, "s", "the right camera's own latency_s (negative: latency_s)",
        Range::atMost(60));
  p.add("width", 640, "px", "published width, other sizes resized (0: as delivered); asked of V4L2",
        Range::between(0, 16384));
  p.add("height", 480, "px", "published height (0: as delivered); asked of V4L2",
        Range::between(0, 16384));
  p.add("fps", 30.0, "Hz", "frame rate asked of V4L2 cameras (0: the driver's default)",
        Range::between(0, 1000));
  p.add("fourcc", "", "pixel format asked of V4L2 cameras, e.g. MJPG (empty: the driver's)");
  p.add("pair_tolerance_s", 0.015, "s",
        "pair frames whose capture times differ by at most this (keep below half a frame period)",
        Range::between(0, 10));
  p.add("pair_buffer_frames", 30, "",
        "frames a side waiting for a partner (live: the oldest beyond unmatched; files wait)",
        Range::between(1, 10000));
  p.add("no_pair_warn_s", 2.0, "s", "status ERROR when both sides deliver but none pair this long",
        Range::above(0));
  p.add("ptz_history_s", 2.0, "s", "PTZ_STATE kept for stamping frames", Range::between(0, 3600));
  p.add("max_ptz_extrapolation_s", 0.1, "s",
        "frames further outside the PTZ_STATE history get the nearest state, counted ptz_stale; "
        "also the longest a pair waits after its capture for a PTZ_STATE",
        Range::between(0, 60));
  p.add("max_rate_hz", 30.0, "Hz", "publish at most this many pairs a second (0: every pair)",
        Range::between(0, 1000));
  p.add("source_timeout_s", 2.0, "s",
        "a streaming live source without a frame this long is reopened (not files)",
        Range::above(0));
  p.add("open_timeout_s", 5.0, "s",
        "a live connection without a first frame this long is reopened (not files)",
        Range::above(0));
  p.add("retry_initial_s", 0.5, "s", "first reconnection delay; doubles after each failure",
        Range::above(0));
  p.add("retry_max_s", 8.0, "s", "longest reconnection delay", Range::above(0));
  p.addOrder("retry_initial_s", "retry_max_s", false);
  declareTriggerParams(p);
}

CameraConfig cameraConfigFrom(const Params& p) {
  // The numbers' ranges and orders are their declarations'.
  p.checkOrders();  // values set() after parsing
  const int width = p.getInt("width"), height = p.getInt("height");
  if ((width == 0) != (height == 0)) {
    const bool w0 = width == 0;
    throw p.invalid(w0 ? "width" : "height",
                    std::string("may be 0 only when ") + (w0 ? "height" : "width") + " is 0 too");
  }
  const std::string fourcc = p.getString("fourcc");
  if (!fourcc.empty() && fourcc.size() != 4) throw p.invalid("fourcc", "must be four characters");
  CameraConfig c;
  for (size_t s = 0; s < 2; ++s) {
    const std::string side = kSide[s];
    // A file or folder named in the config file is found from its folder; devices, URLs and
    // pipelines are taken as they are.
    c.source[s] = parseSource(p.getString(side + "_source"), side + "_source");
    if (!c.source[s].live())
      c.source[s] = parseSource(p.getPath(side + "_source"), side + "_source");
    CaptureOptions& o = c.capture[s];
    o.width = width;
    o.height = height;
    o.fps = p.getDouble("fps");
    o.fourcc = fourcc;
    const double own_latency_s = p.getDouble(side + "_latency_s");
    o.latency_s = own_latency_s >= 0 ? own_latency_s : p.getDouble("latency_s");
    o.file_fps = p.getDouble("file_fps");
    o.loop = p.getBool("loop");
    const std::string ts = p.getPath(side + "_timestamps");
    if (c.source[s].live()) {
      if (!ts.empty()) {
        throw ConfigError("parameter '" + side + "_timestamps' is for video files and folders; " +
                          side + "_source is a " + sourceKindName(c.source[s].kind));
      }
    } else if (!ts.empty()) {
      o.timestamps = readTimestamps(ts);
    } else if (exists(defaultTimestampsPath(c.source[s].text))) {
      o.timestamps = readTimestamps(defaultTimestampsPath(c.source[s].text));
    }
  }
  c.supervisor = {p.getDouble("source_timeout_s"), p.getDouble("open_timeout_s"),
                  p.getDouble("retry_initial_s"), p.getDouble("retry_max_s")};
  c.pairer = {std::llround(p.getDouble("pair_tolerance_s") * 1e6),
              static_cast<size_t>(p.getInt("pair_buffer_frames")), p.getDouble("no_pair_warn_s")};
  c.ptz_history_s = p.getDouble("ptz_history_s");
  c.max_ptz_extrapolation_s = p.getDouble("max_ptz_extrapolation_s");
  c.max_rate_hz = p.getDouble("max_rate_hz");
  c.trigger = triggerParamsFrom(p, {c.source[0].live(), c.source[1].live()});
  return c;
}

StereoCamera::StereoCamera(const CameraConfig& config, std::array<SourceFactory, 2> factories,
                           const TriggerLog* pulses)
    : config_(config),
      sources_{SourceSupervisor("left source " + config.source[0].text, std::move(factories[0]),
                                config.supervisor, config.source[0].live()),
               SourceSupervisor("right source " + config.source[1].text, std::move(factories[1]),
                                config.supervisor, config.source[1].live())},
      pairer_(config.pairer),
      history_(config.ptz_history_s, config.max_ptz_extrapolation_s) {
  if (config.trigger.enabled()) {
    if (!pulses) throw std::invalid_argument("StereoCamera: a trigger line without its pulses");
    trigger_.emplace(*pulses, config.trigger.windowUs(), config.pairer.no_pair_warn_s,
                     config.trigger.own_latency);
  }
}

bool StereoCamera::onPtzState(int64_t utime, const PtzPose& left, const PtzPose& right) {
  return history_.add(utime, left, right);
}

std::vector<StampedPair> StereoCamera::step(int64_t now_utime) {
  std::vector<CapturedFrame> frames;
  for (size_t s = 0; s < 2; ++s) {
    frames.clear();
    // Recordings wait while their side has its pairing buffer full (the other side is behind,
    // e.g. a slow decoder); a live camera cannot wait: its oldest frames are unmatched instead.
    size_t room = static_cast<size_t>(-1);
    if (!config_.source[s].live()) {
      const size_t waiting = pairer_.waiting(static_cast<Side>(s));
      room = waiting < config_.pairer.buffer_frames ? config_.pairer.buffer_frames - waiting : 0;
    }
    sources_[s].step(static_cast<double>(now_utime) * 1e-6, &frames, room);
    for (auto& f : frames) {
      if (f.resized) ++resized_[s];
      if (f.buffer_time) ++buffer_stamped_[s];
      if (trigger_) {
        const auto pulse = trigger_->match(static_cast<Side>(s), f.capture_utime, now_utime);
        if (!pulse) continue;
        f.capture_utime = *pulse;
      }
      pairer_.add(static_cast<Side>(s), std::move(f), now_utime);
    }
    if (!ended_[s] && sources_[s].state() == SourceSupervisor::State::kEnded) {
      ended_[s] = true;
      pairer_.setEnded(static_cast<Side>(s));
    }
  }
  for (auto& pair : pairer_.takePairs()) {
    const int64_t t = pair.left.capture_utime;
    if (config_.max_rate_hz > 0) {
      // At most max_rate_hz in capture time; a frame early by up to a quarter period passes.
      const auto period = static_cast<int64_t>(1e6 / config_.max_rate_hz);
      if (published_any_ && t < next_allowed_utime_ - period / 4) {
        ++skipped_rate_;
        continue;
      }
      next_allowed_utime_ = (published_any_ ? std::max(next_allowed_utime_, t) : t) + period;
    }
    published_any_ = true;
    held_.push_back({std::move(pair), now_utime});
  }
  std::vector<StampedPair> out;
  // In order: a later pair is never ready before an earlier one is.
  while (!held_.empty() && ready(held_.front(), now_utime)) {
    out.push_back(stamp(std::move(held_.front()), now_utime));
    held_.pop_front();
  }
  return out;
}

int64_t StereoCamera::releaseUtime(const Held& h) const {
  // Live capture times are wall clock; a recording's may lie anywhere (its wait starts when the
  // pair is made, and past recordings wait not at all).
  const int64_t latest = std::max(h.pair.left.capture_utime, h.pair.right.capture_utime);
  return std::min(latest, h.made_utime) + std::llround(config_.max_ptz_extrapolation_s * 1e6);
}

bool StereoCamera::ready(const Held& h, int64_t now_utime) const {
  const std::optional<int64_t> newest = history_.newestUtime();
  if (!newest) return true;  // no PTZ_STATE yet (no driver running): waiting would gain nothing
  const int64_t latest = std::max(h.pair.left.capture_utime, h.pair.right.capture_utime);
  const auto max_extrapolation_us = std::llround(config_.max_ptz_extrapolation_s * 1e6);
  // Both captures covered: interpolated. The newest state too old to stamp it: stale whatever.
  return *newest >= latest || latest - *newest > max_extrapolation_us ||
         now_utime >= releaseUtime(h);
}

StampedPair StereoCamera::stamp(Held h, int64_t now_utime) {
  StereoPair& pair = h.pair;
  StampedPair sp;
  const PtzLookup l = history_.at(Side::kLeft, pair.left.capture_utime);
  const PtzLookup r = history_.at(Side::kRight, pair.right.capture_utime);
  sp.left_pose = l.pose;
  sp.right_pose = r.pose;
  sp.ptz_stale = l.stale || r.stale;
  if (sp.ptz_stale) ++ptz_stale_;
  last_stale_ = sp.ptz_stale;
  const std::optional<int64_t> newest = history_.newestUtime();
  if (newest && *newest < std::max(pair.left.capture_utime, pair.right.capture_utime)) {
    ++ptz_extrapolated_;  // no state at or after its capture came in time: the newest one
  }
  passed_through_ += (pair.left.jpeg.empty() ? 0 : 1) + (pair.right.jpeg.empty() ? 0 : 1);
  sp.first_arrival_utime = pair.first_arrival_utime;
  sp.ptz_wait_us = now_utime - h.made_utime;
  sp.left = std::move(pair.left);
  sp.right = std::move(pair.right);
  return sp;
}

std::optional<int64_t> StereoCamera::heldUntilUtime() const {
  if (held_.empty()) return std::nullopt;
  return releaseUtime(held_.front());
}

bool StereoCamera::finished() const {
  return ended_[0] && ended_[1] && pairer_.waiting(Side::kLeft) == 0 &&
         pairer_.waiting(Side::kRight) == 0 && held_.empty();
}

Health StereoCamera::health(int64_t now_utime, std::string* message) const {
  const double now_s = static_cast<double>(now_utime) * 1e-6;
  std::vector<std::string> errors, warnings;
  for (const auto& s : sources_) {
    const std::string problem = s.problem(now_s);
    if (!problem.empty()) errors.push_back(problem);
  }
  const std::string no_pair = pairer_.noPairMessage(now_utime);
  if (!no_pair.empty()) errors.push_back(no_pair);
  if (trigger_) {
    bool error = false;
    const std::string problem = trigger_->problem(now_utime, &error);
    if (!problem.empty()) (error ? errors : warnings).push_back(problem);
  }
  if (last_stale_) {
    warnings.push_back(
        "frames without a PTZ_STATE near their capture time: stamped with the nearest state "
        "(home without any)");
  }
  for (size_t s = 0; s < 2; ++s) {
    if (ended_[s] && !ended_[1 - s]) warnings.push_back(std::string(kSide[s]) + " source ended");
    // A recording does not heal: the last file skipped stays named.
    if (sources_[s].skipped() > 0) {
      warnings.push_back(std::string(kSide[s]) +
                         " source: " + std::to_string(sources_[s].skipped()) +
                         " image file(s) skipped, the last: " + sources_[s].lastSkipped());
    }
  }
  if (!errors.empty()) {
    *message = joined(errors);
    return Health::kError;
  }
  *message = joined(warnings);
  return warnings.empty() ? Health::kOk : Health::kWarn;
}

std::map<std::string, int64_t> StereoCamera::counters() const {
  std::map<std::string, int64_t> c;
  for (size_t s = 0; s < 2; ++s) {
    const std::string side = kSide[s];
    c["frames_" + side] = sources_[s].frames();
    c["unmatched_" + side] = pairer_.unmatched(static_cast<Side>(s));
    c["resized_" + side] = resized_[s];
    c["buffer_stamped_" + side] = buffer_stamped_[s];
    c["reconnects_" + side] = sources_[s].reconnects();
    c["source_overflow_" + side] = sources_[s].overflowed();
    c["ended_" + side] = ended_[s] ? 1 : 0;
    c["skipped_files_" + side] = sources_[s].skipped();
  }
  c["pairs"] = pairer_.pairs();
  c["pairs_skipped_rate"] = skipped_rate_;
  c["images_passed_through"] = passed_through_;
  c["ptz_stale"] = ptz_stale_;
  c["ptz_extrapolated"] = ptz_extrapolated_;
  c["ptz_history_restarts"] = history_.restarts();
  c["abandoned_readers"] = abandonedReaders();
  if (trigger_) trigger_->addCounters(&c);
  return c;
}

std::vector<std::string> StereoCamera::takeEvents() {
  std::vector<std::string> out;
  for (auto& s : sources_) {
    for (auto& e : s.takeEvents()) out.push_back(std::move(e));
  }
  return out;
}

}  // namespace ptz::driver
