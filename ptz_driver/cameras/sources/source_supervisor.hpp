// Keeps one camera's frames coming: connects, notices a source that cannot be opened, fails to
// read (unplugged) or goes quiet, and reconnects with exponential back-off. Explicit time, no
// threads, no sleeps: the caller steps it (ptz-camera's loop; the tests with a fake source).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ptz_driver/cameras/sources/frame_source.hpp"
#include "ptz_driver/io/backoff.hpp"

namespace ptz::driver {

struct SupervisorParams {
  double source_timeout_s = 2.0;  // live, streaming: no frame for this long -> reconnect
  double open_timeout_s = 5.0;    // live, connecting: no first frame for this long -> reconnect
  double retry_initial_s = 0.5;   // first back-off; doubles after every failed attempt
  double retry_max_s = 8.0;       // back-off ceiling
};

class SourceSupervisor {
 public:
  enum class State { kWaiting, kConnecting, kStreaming, kEnded };

  // name: how messages call the source, e.g. "right source rtsp://cam/stream". live: false for
  // files and folders, which have no silence or open timeout: their reader legitimately waits
  // for the next frame's recorded time (a gap in a recording), and they end or fail by themselves.
  SourceSupervisor(std::string name, SourceFactory factory, SupervisorParams params,
                   bool live = true);

  // At now_s: connects when a retry is due, appends the frames the source has to *frames (at
  // most max_frames: the caller has no room for more, which does not count as silence), gives
  // the connection up when it failed or stayed quiet too long (retry after the back-off).
  void step(double now_s, std::vector<CapturedFrame>* frames,
            size_t max_frames = static_cast<size_t>(-1));

  State state() const { return state_; }
  // Connections given up (each is followed by a retry).
  int64_t reconnects() const { return reconnects_; }
  int64_t frames() const { return frames_; }
  int64_t overflowed() const;
  // Image files skipped because they did not decode, and why the last one was ("" when none).
  int64_t skipped() const { return skipped_; }
  const std::string& lastSkipped() const { return last_skipped_; }
  // When the next attempt starts (kWaiting) and the back-off after the next failure.
  double retryAtS() const { return retry_.retryAtS(); }
  double nextDelayS() const { return retry_.nextDelayS(); }
  // What is wrong, for the status: "" while streaming, during the first connection and at a
  // clean end of file. E.g. "right source rtsp://x: no frame for 2.1 s, reconnecting in 1.0 s".
  std::string problem(double now_s) const;
  // What happened since the last call (gave up, reconnected, ended), for the log; once each.
  std::vector<std::string> takeEvents();

 private:
  void giveUp(double now_s, const std::string& why);
  void noteSkipped();  // before the connection is dropped

  std::string name_;
  SourceFactory factory_;
  SupervisorParams params_;
  bool live_;
  std::unique_ptr<FrameSource> source_;
  State state_ = State::kWaiting;
  Backoff retry_;  // the first step connects at once
  double attempt_start_s_ = 0, last_frame_s_ = 0;
  bool had_frame_ = false;  // in this connection
  int64_t reconnects_ = 0, frames_ = 0, overflowed_done_ = 0;
  std::string why_;  // the last failure
  int64_t skipped_ = 0, skipped_in_source_ = 0;
  std::string last_skipped_;
  std::vector<std::string> events_;
};

}  // namespace ptz::driver
