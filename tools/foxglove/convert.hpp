// LCM messages of a run -> Foxglove messages (JSON encoding, Foxglove's published schemas where
// one fits, the project's own JSON schemas for the rest). Shared by ptz-mcap (logs -> MCAP) and
// ptz-foxglove-bridge (live, over the Foxglove WebSocket protocol), so both show the same topics.
// Knows nothing of transport: bytes and a receive time in, JSON texts out.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::foxglove {

// A topic the converter may produce. The schema is JSON Schema text (encoding "jsonschema");
// messages are JSON (encoding "json").
struct Topic {
  std::string name;         // e.g. "/left/image"
  std::string schema_name;  // e.g. "foxglove.CompressedImage"
  std::string schema_json;
};

struct Message {
  int topic = 0;                // index into Converter::topics()
  int64_t log_time_ns = 0;      // when it was received (the log event's time)
  int64_t publish_time_ns = 0;  // the data's own time (capture time of its frame)
  std::string json;
};

struct ConvertOptions {
  // Images (and their calibration and annotations) at most this often, by capture time; 0: all.
  double image_rate_hz = 0;
  // Images wider than this are scaled down (JPEG re-encoded); 0: as they are.
  int image_max_width_px = 0;
  int jpeg_quality = 80;  // for raw frames and scaled images
  // Clouds at most this often, by capture time; 0: all.
  double cloud_rate_hz = 0;
  // The prefix of the project's channel names (a simulated and a real rig on one network);
  // channels without it are not shown.
  std::string channel_prefix;
};

// Microseconds as the nanoseconds of MCAP and the Foxglove WebSocket protocol: negative ones as 0,
// too large ones as INT64_MAX.
int64_t utimeToNs(int64_t utime);

// Whether anyone wants a topic (an index into Converter::topics()).
using TopicFilter = std::function<bool(int topic)>;

class Converter {
 public:
  Converter(StereoRig rig, ConvertOptions options);
  ~Converter();
  Converter(const Converter&) = delete;
  Converter& operator=(const Converter&) = delete;

  // Every topic convert() may produce; fixed at construction, but for /status/<process>, which
  // is added when a process's first status arrives (indexes never change).
  const std::vector<Topic>& topics() const;

  // One LCM message, checked against its bytes before it is decoded. Returns what it converts
  // to (often several messages, sometimes none: a channel not shown, a decimated image). A
  // message that fails its check is counted in dropped() by channel and reason.
  // With wanted, only the topics it wants are made, and a message none of whose topics it wants
  // is not even decoded (counted in notWanted()); /status/ topics are added all the same.
  std::vector<Message> convert(const std::string& channel, const void* data, size_t size,
                               int64_t receive_utime, const TopicFilter& wanted = {});

  // A STEREO_FRAME or STEREO_PREVIEW its caller has decoded already (it needs it too): what
  // convert() makes of its bytes, without a second decode.
  std::vector<Message> convertFrame(const std::string& channel, const ptzstereo::stereo_frame_t& m,
                                    int64_t receive_utime);

  // Dropped messages: "CHANNEL: reason" -> count.
  const std::map<std::string, int64_t>& dropped() const;
  // Messages converted per LCM channel, and LCM channels seen but not shown.
  const std::map<std::string, int64_t>& converted() const;
  const std::map<std::string, int64_t>& ignored() const;
  // Image messages made (the costly part: a JPEG, base64); messages none of whose topics was
  // wanted.
  int64_t imagesConverted() const;
  int64_t notWanted() const;
  // LCM messages decoded per channel (without the prefix).
  const std::map<std::string, int64_t>& decoded() const;

 private:
  std::vector<Message> convertWanted(const std::string& channel, const void* data, size_t size,
                                     int64_t receive_utime);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ptz::foxglove
