#include "common/transport/intake.hpp"

#include <utility>

#include "common/transport/message_check.hpp"

namespace ptz {

FreshnessGate::FreshnessGate(StatusReporter& status, FreshnessLimits limits, std::string what,
                             std::string reason_prefix, CaptureClock clock)
    : status_(status),
      limits_(limits),
      what_(std::move(what)),
      reason_prefix_(std::move(reason_prefix)),
      clock_(clock) {}

bool FreshnessGate::fresh(int64_t capture_utime, int64_t publish_utime, int64_t now_utime) const {
  return judge(capture_utime, publish_utime, now_utime) == Freshness::kFresh;
}

Freshness FreshnessGate::judge(int64_t capture_utime, int64_t publish_utime,
                               int64_t now_utime) const {
  const bool wall_clock =
      clock_ == CaptureClock::kWall || captureOnWallClock(capture_utime, publish_utime);
  return judgeFreshness(capture_utime, publish_utime, now_utime, limits_, wall_clock);
}

bool FreshnessGate::admit(const std::string& channel, int64_t capture_utime, int64_t publish_utime,
                          int64_t frame_seq, int64_t received_utime) {
  const Freshness fresh = judge(capture_utime, publish_utime, received_utime);
  if (fresh == Freshness::kFresh) return true;
  const std::string reason = freshnessReason(fresh);
  status_.countDropped(channel, reason_prefix_ + reason);
  log_.warn(reason, status_.process() + ": dropped a " + reason + " " + what_ + " (frame " +
                        std::to_string(frame_seq) + ", published " +
                        formatNumber(saturatingDiffUs(received_utime, publish_utime) / 1000.0) +
                        " ms ago)");
  return false;
}

FrameIntake::FrameIntake(StatusReporter& status, std::string channel, FreshnessLimits limits,
                         cv::Size rig_size, std::string rig_source)
    : status_(status),
      channel_(std::move(channel)),
      fresh_(status, limits, "frame"),
      rig_size_(rig_size),
      rig_source_(std::move(rig_source)) {}

void FrameIntake::drop(int64_t seq, const std::string& reason, const std::string& why) {
  status_.countDropped(channel_, reason);
  log_.warn(reason, status_.process() + ": dropped frame " + std::to_string(seq) + ": " + why);
}

bool FrameIntake::accept(const ptzstereo::stereo_frame_t& m, int64_t received_utime) {
  if (!fresh_.admit(channel_, m.utime, m.publish_utime, m.seq, received_utime)) return false;
  std::string why;
  if (!checkStereoFrame(m, kMaxImageSidePx, &why)) {
    drop(m.seq, "bad_image", why);
    return false;
  }
  if (!checkFrameMatchesRig(m, rig_size_.width, rig_size_.height, &why)) {
    const std::string rig =
        rig_source_.empty() ? "the built-in rig" : "rig file '" + rig_source_ + "'";
    drop(m.seq, "size_mismatch",
         why + " (" + rig + "): calibrate at this image size (ptz-calibrate)");
    return false;
  }
  return true;
}

bool FrameIntake::stillFresh(const ptzstereo::stereo_frame_t& m, int64_t now_utime) {
  return fresh_.admit(channel_, m.utime, m.publish_utime, m.seq, now_utime);
}

bool FrameIntake::mayAnswer(const ptzstereo::stereo_frame_t& m, int64_t now_utime) {
  if (fresh_.fresh(m.utime, m.publish_utime, now_utime)) return true;
  status_.increment("answers_withheld_stale");
  log_.warn("withheld", status_.process() + ": withheld the answers to frame " +
                            std::to_string(m.seq) + ": it went stale while they were sent");
  return false;
}

bool FrameIntake::decode(const ptzstereo::stereo_frame_t& m, cv::Mat* left, cv::Mat* right) {
  std::string why;
  if (decodeImage(m.left, left, &why) && decodeImage(m.right, right, &why)) return true;
  drop(m.seq, "bad_image", why);
  return false;
}

}  // namespace ptz
