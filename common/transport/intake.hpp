// What every process does with a message before it spends a cycle on it, written once: the one
// freshness rule applied the one way (FreshnessGate), and for STEREO_FRAME the frame's own
// consistency and the rig's size (FrameIntake). A message that fails is dropped, counted under
// its reason on its channel and said on stderr (rate-limited), naming the process and the frame.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>

#include "common/freshness.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz {

// Which clock a message's capture time is on: kAuto tells a lockstep run's sim time apart
// (captureOnWallClock); kWall judges every capture time on the wall clock.
enum class CaptureClock { kAuto, kWall };

class FreshnessGate {
 public:
  // what: the message in the warning ("setpoint", "tracks message"); reason_prefix goes before the
  // counted reason (e.g. "setpoint_" counts dropped_setpoint_stale).
  FreshnessGate(StatusReporter& status, FreshnessLimits limits, std::string what,
                std::string reason_prefix = "", CaptureClock clock = CaptureClock::kAuto);
  // Whether a message captured at capture_utime (for frame_seq), published at publish_utime and
  // received at received_utime may be used; if not, it is dropped and counted on channel.
  bool admit(const std::string& channel, int64_t capture_utime, int64_t publish_utime,
             int64_t frame_seq, int64_t received_utime);
  // The same judgement, neither counted nor said.
  bool fresh(int64_t capture_utime, int64_t publish_utime, int64_t now_utime) const;

 private:
  Freshness judge(int64_t capture_utime, int64_t publish_utime, int64_t now_utime) const;

  StatusReporter& status_;
  FreshnessLimits limits_;
  std::string what_;
  std::string reason_prefix_;
  CaptureClock clock_;
  RateLimitedLog log_;
};

class FrameIntake {
 public:
  // rig_size: the image size the rig is calibrated at; rig_source names it in the warning (a rig
  // file's path, or empty for the built-in rig).
  FrameIntake(StatusReporter& status, std::string channel, FreshnessLimits limits,
              cv::Size rig_size, std::string rig_source);
  // Fresh, well-formed and of the rig's size and colour; else dropped (stale, future, bad_image,
  // size_mismatch).
  bool accept(const ptzstereo::stereo_frame_t& m, int64_t received_utime);
  // Whether an accepted frame is still fresh at now_utime, after its processing; else dropped as
  // stale. A process stopped or starved mid-frame must not answer a frame seconds old.
  bool stillFresh(const ptzstereo::stereo_frame_t& m, int64_t now_utime);
  // Whether an accepted and counted frame's answers may still go at now_utime; else they are
  // withheld (counted answers_withheld_stale, not as a second drop of the frame).
  bool mayAnswer(const ptzstereo::stereo_frame_t& m, int64_t now_utime);
  // Both images as BGR (after accept); else dropped as bad_image.
  bool decode(const ptzstereo::stereo_frame_t& m, cv::Mat* left, cv::Mat* right);
  // Drops frame seq for reason, counted and said with why.
  void drop(int64_t seq, const std::string& reason, const std::string& why);
  const std::string& channel() const { return channel_; }

 private:
  StatusReporter& status_;
  std::string channel_;
  FreshnessGate fresh_;
  cv::Size rig_size_;
  std::string rig_source_;
  RateLimitedLog log_;
};

}  // namespace ptz
