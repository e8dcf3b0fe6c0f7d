// Frames through OpenCV's VideoCapture (V4L2 cameras, GStreamer pipelines, RTSP streams, video
// files) and from image folders. Each connection is read by a thread of its own: a driver that
// blocks (a stalled RTSP stream blocks OpenCV 4.6's read for ~25 s) cannot stall ptz-camera,
// whose supervisor gives such a connection up and opens another. Recorded files are played in
// real time by their recorded capture times.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ptz_driver/cameras/sources/frame_source.hpp"

namespace ptz::driver {

struct CaptureOptions {
  int width = 0, height = 0;        // frames of another size are resized (0: as delivered)
  double fps = 0;                   // requested from V4L2 cameras (0: the driver's default)
  std::string fourcc;               // V4L2 pixel format, e.g. MJPG ("": the driver's default)
  double latency_s = 0;             // live: capture time = grab (or V4L2 buffer) time - this
  std::vector<int64_t> timestamps;  // files: recorded capture times (empty: made from the rate)
  double file_fps = 0;              // files without timestamps (0: the video's rate; folders 30)
  bool loop = false;                // files: start again at the end, times continuing
  size_t queue_frames = 4;          // frames waiting for the consumer (live: the oldest dropped)
  // Folders: a JPEG file of the published size is delivered as its bytes (CapturedFrame::jpeg),
  // not decoded; set when STEREO_FRAME carries JPEG.
  bool pass_jpeg = false;
};

// Maps recorded capture times to wall-clock times for real-time playback, shared by both sides
// so that their recorded offset is kept: the earliest first time of the sides is played when the
// first side starts. Thread-safe.
class PlaybackClock {
 public:
  // A side starts at now_utime with its first recorded time (nullopt: its times are made from
  // its frame rate). Returns the base of made-up times: the wall time playback started.
  int64_t start(std::optional<int64_t> first_recorded_utime, int64_t now_utime);
  // The wall time at which a frame recorded at recorded_utime is due.
  int64_t dueUtime(int64_t recorded_utime) const;

 private:
  mutable std::mutex mutex_;
  bool started_ = false;
  int64_t wall_start_ = 0, origin_ = 0;
};

// Wakes ptz-camera's loop when a reader has a frame: a descriptor to poll (an eventfd).
class FrameNotifier {
 public:
  FrameNotifier();
  ~FrameNotifier();
  FrameNotifier(const FrameNotifier&) = delete;
  FrameNotifier& operator=(const FrameNotifier&) = delete;
  void notify();
  void drain();
  int fd() const { return fd_; }

 private:
  int fd_;
};

// A new connection to `spec` at each call.
SourceFactory makeCaptureFactory(const SourceSpec& spec, const CaptureOptions& options,
                                 std::shared_ptr<PlaybackClock> clock,
                                 std::shared_ptr<FrameNotifier> notifier);

// Reader threads given up while blocked in a driver that have not finished yet.
int abandonedReaders();

// A V4L2 buffer's time (CLOCK_MONOTONIC in ms, as OpenCV's CAP_PROP_POS_MSEC gives it after a
// grab, wrapped modulo 2^32 ms where time_t has 32 bits) on the wall clock, when plausible: not
// after mono_now_ms and at most max_age_ms before.
// Unlike the grab time it does not move when a frame waited in the driver's queue.
std::optional<int64_t> bufferTimeToWallUtime(double buffer_ms, double mono_now_ms,
                                             int64_t wall_now_utime, double max_age_ms = 1000);

// An 8-bit BGR or gray image of the given size (0: keep), converting other depths and BGRA;
// returns whether it had to resize.
bool normaliseImage(cv::Mat* image, int width, int height);

}  // namespace ptz::driver
