#include "tools/mcap_export/exporter.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>

#include "common/transport/message_check.hpp"
#include "common/transport/transport.hpp"
#include "tools/foxglove/lcm_json.hpp"

namespace ptz::tools {

McapExporter::McapExporter(const std::string& path, StereoRig rig, const ExportOptions& options)
    : converter_(std::move(rig), options.convert),
      writer_(path, options.writer),
      metrics_(options.target_class, options.settle_s),
      prefix_(options.convert.channel_prefix) {}

McapExporter::~McapExporter() = default;

void McapExporter::write(const std::string& topic, const std::string& schema_name,
                         const std::string& schema, int64_t log_time_ns, int64_t publish_time_ns,
                         const std::string& json) {
  auto channel = channel_ids_.find(topic);
  if (channel == channel_ids_.end()) {
    auto schema_id = schema_ids_.find(schema_name);
    if (schema_id == schema_ids_.end()) {
      schema_id =
          schema_ids_.emplace(schema_name, writer_.addSchema(schema_name, "jsonschema", schema))
              .first;
    }
    channel =
        channel_ids_.emplace(topic, writer_.addChannel(schema_id->second, topic, "json")).first;
  }
  writer_.write(channel->second, static_cast<uint64_t>(log_time_ns),
                static_cast<uint64_t>(publish_time_ns), json.data(), json.size());
  ++written_[topic];
}

void McapExporter::writeAll(const std::vector<foxglove::Message>& messages) {
  for (const foxglove::Message& m : messages) {
    const foxglove::Topic& t = converter_.topics().at(static_cast<size_t>(m.topic));
    write(t.name, t.schema_name, t.schema_json, m.log_time_ns, m.publish_time_ns, m.json);
  }
}

void McapExporter::add(const std::string& channel, const void* data, size_t size,
                       int64_t receive_utime) {
  ++messages_in_;
  last_receive_utime_ = std::max(last_receive_utime_, receive_utime);
  const bool ours = channel.compare(0, prefix_.size(), prefix_) == 0;
  const std::string name = ours ? channel.substr(prefix_.size()) : channel;
  if (ours && name == channels::kStereoFrame) {
    // The largest message: decoded once, for the images and the run's numbers.
    ptzstereo::stereo_frame_t m;
    std::string why;
    if (decodeChecked(data, size, &m, &why)) {
      ++decoded_[name];
      writeAll(converter_.convertFrame(channel, m, receive_utime));
      metrics_.onFrame(m);
      frame_receive_utime_.emplace(m.seq, receive_utime);
      return;
    }  // else the converter counts it dropped (its check fails before anything is decoded)
  }
  writeAll(converter_.convert(channel, data, size, receive_utime));
  if (ours) feedMetrics(name, data, size);
}

int64_t McapExporter::decodes(const std::string& channel) const {
  const auto count = [&channel](const std::map<std::string, int64_t>& by_channel) {
    const auto it = by_channel.find(channel);
    return it == by_channel.end() ? int64_t{0} : it->second;
  };
  return count(decoded_) + count(converter_.decoded());
}

void McapExporter::feedMetrics(const std::string& channel, const void* data, size_t size) {
  namespace ch = channels;
  std::string why;
  if (channel == ch::kSimTruth) {
    ptzstereo::sim_truth_t m;
    if (decodeChecked(data, size, &m, &why)) metrics_.onTruth(m);
  } else if (channel == ch::kObjectPose) {
    ptzstereo::object_pose_t m;
    if (decodeChecked(data, size, &m, &why)) metrics_.onPose(m);
  } else if (channel == ch::kPtzSetpoint) {
    ptzstereo::ptz_setpoint_t m;
    if (decodeChecked(data, size, &m, &why)) metrics_.onSetpoint(m);
  } else if (channel == ch::kControlState) {
    ptzstereo::control_state_t m;
    if (decodeChecked(data, size, &m, &why)) metrics_.onControlState(m);
  } else if (channel.rfind(ch::kProcessStatusPrefix, 0) == 0) {
    ptzstereo::process_status_t m;
    if (decodeChecked(data, size, &m, &why)) metrics_.onStatus(m);
  }
}

void McapExporter::finish(const std::map<std::string, std::string>& metadata) {
  using nlohmann::json;
  // Per frame: the tracked true object's offset from both image centres (SIM_TRUTH runs only),
  // at the time the frame arrived, so it lines up with the images on the timeline.
  const json centering_sample = {{"frame_seq", 0},    {"left_x_px", 0.5},  {"left_y_px", 0.5},
                                 {"right_x_px", 0.5}, {"right_y_px", 0.5}, {"left_px", 0.5},
                                 {"right_px", 0.5}};
  const std::string centering_schema =
      foxglove::dumpJson(foxglove::schemaOf(centering_sample, "ptzstereo.run_centering"));
  const auto frames = metrics_.frames();
  for (const auto& [seq, offsets] : metrics_.centeringByFrame()) {
    if (offsets.size() != 4) continue;
    const auto received = frame_receive_utime_.find(seq);
    const auto frame = frames.find(seq);
    const int64_t capture_utime = frame == frames.end() ? 0 : frame->second.utime;
    const int64_t log_utime =
        received == frame_receive_utime_.end() ? capture_utime : received->second;
    const json j = {{"frame_seq", seq},
                    {"left_x_px", offsets[0]},
                    {"left_y_px", offsets[1]},
                    {"right_x_px", offsets[2]},
                    {"right_y_px", offsets[3]},
                    {"left_px", std::hypot(offsets[0], offsets[1])},
                    {"right_px", std::hypot(offsets[2], offsets[3])}};
    write("/run/centering", "ptzstereo.run_centering", centering_schema,
          foxglove::utimeToNs(log_utime), foxglove::utimeToNs(capture_utime),
          foxglove::dumpJson(j));
  }
  // The whole run's numbers, once, at the end of the run.
  const json summary = json::parse(metrics_.summary().toJson());
  write("/run/summary", "ptzstereo.run_summary",
        foxglove::dumpJson(foxglove::schemaOf(summary, "ptzstereo.run_summary")),
        foxglove::utimeToNs(last_receive_utime_), foxglove::utimeToNs(last_receive_utime_),
        foxglove::dumpJson(summary));
  std::map<std::string, std::string> run;
  for (auto it = summary.begin(); it != summary.end(); ++it)
    run[it.key()] = foxglove::dumpJson(it.value());
  writer_.addMetadata("run_summary", run);
  writer_.addMetadata("source", metadata);
  writer_.close();
}

}  // namespace ptz::tools
