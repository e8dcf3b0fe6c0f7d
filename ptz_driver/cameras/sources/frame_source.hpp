// Where ptz-camera's images come from: one string per camera, its kind recognised from its form,
// the timestamps files that give recorded videos and image folders their capture times, and the
// interface every frame source offers (a real one: capture_source.hpp; tests: a fake).
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace ptz::driver {

enum class SourceKind { kV4l2, kGstreamer, kRtsp, kVideoFile, kImageFolder };
const char* sourceKindName(SourceKind kind);

struct SourceSpec {
  SourceKind kind = SourceKind::kVideoFile;
  std::string text;       // as given
  int device_index = -1;  // V4L2 given by index
  std::string pipeline;   // GStreamer and RTSP: the pipeline OpenCV opens
  // Live sources are stamped at grab time; files and folders carry recorded times.
  bool live() const;
};

// The rules, the first that applies:
//   only digits ("0")                       V4L2 device index
//   starts with "/dev/video"                V4L2 device path
//   starts with "rtsp://" or "rtsps://"     RTSP URL, opened through GStreamer (rtspPipeline)
//   contains "appsink"                      a GStreamer pipeline, as given
//   an existing folder, or ends in '/'      image sequence: its image files sorted by name
//   anything else                           a video file (FFmpeg or GStreamer decodes it)
// Throws ConfigError naming `what` (the parameter) when empty.
SourceSpec parseSource(const std::string& text, const std::string& what);

// rtspsrc location=URL latency=0 ! decodebin ! videoconvert ! appsink drop=true max-buffers=1
// sync=false: the newest decoded frame, never a backlog.
std::string rtspPipeline(const std::string& url);

// Beside the video or folder: left.avi -> left.avi.timestamps, frames/ -> frames.timestamps.
std::string defaultTimestampsPath(const std::string& source);

// One capture time per line, integer microseconds (Unix epoch), strictly increasing; blank lines
// and lines starting with '#' are skipped. Throws ConfigError naming the file and the line.
std::vector<int64_t> readTimestamps(const std::string& path);

// The image files of a folder (extensions OpenCV reads), sorted by name; throws ConfigError
// naming the folder when it holds none.
std::vector<std::string> listImageFiles(const std::string& folder);

struct CapturedFrame {
  cv::Mat image;  // decoded (8-bit BGR); empty when the frame is only jpeg
  // The JPEG as the source delivered it, checked (checkPassThroughJpeg) and of the published
  // size: published as it is, decoded only for what needs pixels (previews).
  std::vector<uint8_t> jpeg;
  cv::Size jpeg_size;
  int64_t capture_utime = 0;  // live: grab (V4L2: buffer) time minus latency; files: recorded
  bool buffer_time = false;   // stamped from the V4L2 buffer's time, not the grab's
  int64_t index = 0;          // frame number within this connection (files: within the file)
  bool resized = false;       // delivered at another size than configured
};

// One connection to a camera or file. Opening may take a while, so it happens behind poll();
// destroying the source ends the connection (a reader blocked in a driver is left to finish).
class FrameSource {
 public:
  enum class Poll { kNothing, kFrame, kFailed, kEnded };
  virtual ~FrameSource() = default;
  // Never blocks: a frame when one is waiting, kFailed (see error()) when the source cannot be
  // opened or a read failed, kEnded at the end of a file, else kNothing.
  virtual Poll poll(CapturedFrame* frame) = 0;
  virtual std::string error() const = 0;
  // Frames the reader dropped because nobody took them in time (live sources).
  virtual int64_t overflowed() const { return 0; }
  // Image files of a folder that did not decode, skipped (their partners go unmatched), and why
  // the last one was (naming the file).
  virtual int64_t skipped() const { return 0; }
  virtual std::string lastSkipped() const { return ""; }
};

// Makes a new connection each time it is called (the supervisor's reconnects).
using SourceFactory = std::function<std::unique_ptr<FrameSource>()>;

}  // namespace ptz::driver
