// A run's LCM messages -> an MCAP file that Foxglove/Lichtblick and PlotJuggler open: the
// converter's topics (tools/foxglove/convert.hpp), then the run's numbers (tools/logs/
// run_metrics.hpp) as plottable messages (/run/centering per frame, /run/summary) and as the
// file's "run_summary" metadata. Fed message by message, from a log or live.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "tools/foxglove/convert.hpp"
#include "tools/logs/run_metrics.hpp"
#include "tools/mcap/mcap_writer.hpp"

namespace ptz::tools {

struct ExportOptions {
  foxglove::ConvertOptions convert;
  mcap::WriterOptions writer;
  std::string target_class = "red_ball";  // for the run's numbers
  double settle_s = 2.0;
};

class McapExporter {
 public:
  // Writes to path (the caller renames it into place once finish() returned).
  McapExporter(const std::string& path, StereoRig rig, const ExportOptions& options);
  ~McapExporter();

  // One LCM message and when it was received (the log event's time), microseconds.
  void add(const std::string& channel, const void* data, size_t size, int64_t receive_utime);
  // The run's numbers, metadata (e.g. the source log), the summary and footer; closes the file.
  void finish(const std::map<std::string, std::string>& metadata);

  const foxglove::Converter& converter() const { return converter_; }
  // Messages written per MCAP topic.
  const std::map<std::string, int64_t>& written() const { return written_; }
  int64_t messagesIn() const { return messages_in_; }
  // LCM messages of a channel (without the prefix) decoded, by the converter and for the
  // run's numbers together.
  int64_t decodes(const std::string& channel) const;
  uint64_t bytesWritten() const { return writer_.bytesWritten(); }

 private:
  void write(const std::string& topic, const std::string& schema_name, const std::string& schema,
             int64_t log_time_ns, int64_t publish_time_ns, const std::string& json);
  void writeAll(const std::vector<foxglove::Message>& messages);
  // The run's numbers of a channel (without the prefix) but STEREO_FRAME.
  void feedMetrics(const std::string& channel, const void* data, size_t size);

  foxglove::Converter converter_;
  mcap::Writer writer_;
  RunMetrics metrics_;
  std::map<std::string, uint16_t> schema_ids_, channel_ids_;
  std::map<std::string, int64_t> written_;
  std::map<std::string, int64_t> decoded_;          // for the run's numbers, by channel
  std::map<int64_t, int64_t> frame_receive_utime_;  // seq -> when its STEREO_FRAME arrived
  std::string prefix_;
  int64_t messages_in_ = 0;
  int64_t last_receive_utime_ = 0;
};

}  // namespace ptz::tools
