// ptz-camera without LCM: two supervised frame sources, stereo pairs by capture time, each image
// stamped with its camera's pan/tilt/zoom at its capture time, a publish-rate limit; its
// parameters, counters and health. ptz-camera's main only moves messages.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "ptz_driver/cameras/ptz_history.hpp"
#include "ptz_driver/cameras/sources/capture_source.hpp"
#include "ptz_driver/cameras/sources/source_supervisor.hpp"
#include "ptz_driver/cameras/stereo_pairer.hpp"
#include "ptz_driver/cameras/trigger.hpp"

namespace ptz::driver {

struct CameraConfig {
  std::array<SourceSpec, 2> source;  // left, right
  std::array<CaptureOptions, 2> capture;
  SupervisorParams supervisor;
  PairerParams pairer;
  double ptz_history_s = 2.0, max_ptz_extrapolation_s = 0.1;
  double max_rate_hz = 30.0;  // 0: every pair
  TriggerParams trigger;      // a hardware trigger line, when enabled()
};

// Everything but the transport and the image encoding (lcm_url, encoding, jpeg_quality, ...).
void declareCameraParams(Params& p);
// Reads and checks them, and the timestamps files; ConfigError names the parameter or the file.
CameraConfig cameraConfigFrom(const Params& p);

struct StampedPair {
  CapturedFrame left, right;
  PtzPose left_pose, right_pose;  // each at its own image's capture time
  bool ptz_stale = false;
  int64_t first_arrival_utime = 0;  // when the earlier frame of the pair arrived (wall clock)
  int64_t ptz_wait_us = 0;          // how long it was held for a PTZ_STATE after its capture
};

enum class Health { kOk, kWarn, kError };

class StereoCamera {
 public:
  // factories: left, right (capture sources in ptz-camera, fakes in tests). With a trigger,
  // `pulses` are the pulses sent (it must outlive the camera): each frame is stamped with the
  // pulse it answers, and a frame that answers none is not used.
  StereoCamera(const CameraConfig& config, std::array<SourceFactory, 2> factories,
               const TriggerLog* pulses = nullptr);

  // False (ignored) when not after the newest state (see PtzHistory::add).
  bool onPtzState(int64_t utime, const PtzPose& left, const PtzPose& right);
  // Takes the sources' frames at now_utime (wall clock); returns the pairs to publish. A pair is
  // held until a PTZ_STATE at or after both its capture times has arrived, so that its poses are
  // interpolated rather than the last state's (states arrive 20-40 ms after their time), or until
  // max_ptz_extrapolation_s after its capture (then the nearest state). Not held when no state
  // ever arrived or the newest is already too old to stamp it (no driver, or it stopped).
  std::vector<StampedPair> step(int64_t now_utime);
  // When a held pair's wait runs out (wall clock; step it then), nullopt when none is held.
  std::optional<int64_t> heldUntilUtime() const;
  // Both sources ended (files without loop) and every frame is decided and released.
  bool finished() const;

  Health health(int64_t now_utime, std::string* message) const;
  // The pairer's complaint (part of health's message): "" or "no stereo pair in 2.0 s: ...".
  std::string noPairMessage(int64_t now_utime) const { return pairer_.noPairMessage(now_utime); }
  std::map<std::string, int64_t> counters() const;
  // Log lines: sources given up, reconnected, ended.
  std::vector<std::string> takeEvents();

 private:
  CameraConfig config_;
  struct Held {
    StereoPair pair;
    int64_t made_utime;  // wall clock
  };
  bool ready(const Held& h, int64_t now_utime) const;
  int64_t releaseUtime(const Held& h) const;
  StampedPair stamp(Held h, int64_t now_utime);

  std::array<SourceSupervisor, 2> sources_;
  StereoPairer pairer_;
  PtzHistory history_;
  std::optional<TriggerMatcher> trigger_;
  std::deque<Held> held_;  // waiting for their PTZ_STATE, oldest first
  std::array<bool, 2> ended_{false, false};
  std::array<int64_t, 2> resized_{0, 0}, buffer_stamped_{0, 0};
  int64_t skipped_rate_ = 0, ptz_stale_ = 0, ptz_extrapolated_ = 0;
  int64_t passed_through_ = 0;  // images released as their source's JPEG bytes
  bool last_stale_ = false, published_any_ = false;
  int64_t next_allowed_utime_ = 0;
};

}  // namespace ptz::driver
