// The converter of ptz-mcap and ptz-foxglove-bridge (tools/foxglove/convert.hpp): a run of LCM
// messages, each on a channel the input picks. Input: one byte of options (bit 0: images scaled
// to 64 px, bit 1: images at 10 Hz, bit 2: clouds at 1 Hz, bit 3: the channel prefix "SIM_"),
// then records of [channel byte][u16 LE length][bytes]. Properties: nothing throws; every message
// is on a topic convert() has listed, its JSON parses (valid UTF-8 whatever the LCM strings held)
// and carries the receive time; topics listed at construction never change; status topics and
// the counters' keys stay bounded.
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "common/transport/transport.hpp"
#include "fuzz/fuzz_support.hpp"
#include "tools/foxglove/convert.hpp"

namespace {

namespace ch = ptz::channels;

constexpr size_t kMaxStatusTopics = 64;
constexpr size_t kMaxCountKeys = 256;

// Channel byte -> channel name: the contract's channels, then statuses of many processes (the
// status topics' bound), then channels the converter does not show.
std::string channelOf(uint8_t b, const std::string& prefix) {
  static const char* const known[] = {
      ch::kStereoFrame,   ch::kStereoPreview,    ch::kPtzState,   ch::kPtzSetpoint,
      ch::kControlState,  ch::kObjectDetections, ch::kObjectPose, ch::kObjectTracks,
      ch::kSimTruth,      ch::kTargetSelect,     ch::kPointCloud, ch::kPointCloudPreview,
      ch::kDisparityImage};
  constexpr uint8_t n = sizeof(known) / sizeof(known[0]);
  if (b < n) return prefix + known[b];
  if (b < 200) return prefix + ch::kProcessStatusPrefix + std::to_string(b);
  if (b < 250) return "OTHER_" + std::string(1, static_cast<char>(b)) + "\xff";
  return prefix.empty() ? "SIM_PTZ_STATE" : "PTZ_STATE";  // another rig's channel
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  ptz::foxglove::ConvertOptions options;
  options.image_max_width_px = (data[0] & 1) ? 64 : 0;
  options.image_rate_hz = (data[0] & 2) ? 10 : 0;
  options.cloud_rate_hz = (data[0] & 4) ? 1 : 0;
  options.channel_prefix = (data[0] & 8) ? "SIM_" : "";
  ptz::foxglove::Converter converter(ptz::StereoRig::makeDefault(), options);
  const std::vector<ptz::foxglove::Topic> listed = converter.topics();

  int64_t receive_utime = 1'700'000'000'000'000;
  for (size_t at = 1; at + 3 <= size;) {
    const std::string channel = channelOf(data[at], options.channel_prefix);
    const size_t length = std::min<size_t>(data[at + 1] | (data[at + 2] << 8), size - at - 3);
    const uint8_t* bytes = data + at + 3;
    at += 3 + length;
    receive_utime += 33'333;

    const auto out = converter.convert(channel, bytes, length, receive_utime);
    const auto& topics = converter.topics();
    for (const auto& m : out) {
      FUZZ_CHECK(m.topic >= 0 && static_cast<size_t>(m.topic) < topics.size(),
                 "topic index " + std::to_string(m.topic) + " of " + std::to_string(topics.size()));
      FUZZ_CHECK(m.log_time_ns == receive_utime * 1000,
                 topics[m.topic].name + ": log time " + std::to_string(m.log_time_ns));
      FUZZ_CHECK(nlohmann::json::accept(m.json),
                 topics[m.topic].name + ": not JSON: " + m.json.substr(0, 200));
    }
  }
  const auto& topics = converter.topics();
  FUZZ_CHECK(topics.size() <= listed.size() + kMaxStatusTopics,
             std::to_string(topics.size()) + " topics");
  for (size_t i = 0; i < listed.size(); ++i) {
    FUZZ_CHECK(topics[i].name == listed[i].name && topics[i].schema_json == listed[i].schema_json,
               "topic " + std::to_string(i) + " changed: " + topics[i].name);
  }
  for (size_t i = listed.size(); i < topics.size(); ++i) {
    FUZZ_CHECK(
        topics[i].name.rfind("/status/", 0) == 0 && nlohmann::json::accept(topics[i].schema_json),
        "added topic " + topics[i].name);
  }
  for (const auto* counts : {&converter.dropped(), &converter.converted(), &converter.ignored()}) {
    FUZZ_CHECK(counts->size() <= kMaxCountKeys + 1, std::to_string(counts->size()) + " keys");
    for (const auto& [key, n] : *counts) {
      FUZZ_CHECK(n > 0 && key.size() <= 256, "counter '" + key + "' = " + std::to_string(n));
    }
  }
  return 0;
}
