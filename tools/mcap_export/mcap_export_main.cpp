// ptz-mcap: an LCM log (or, with --live, the live traffic) as an MCAP file that Foxglove,
// Lichtblick and PlotJuggler open: both images with their calibration at the frame's zoom, the
// cameras' frames following pan and tilt, the cloud, tracks and truth in 3D, the PTZ, control and
// status messages as plottable JSON, and the run's numbers. Written under a temporary name and
// renamed at the end: a failed export leaves no file.
#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <set>
#include <string>

#include "common/config.hpp"
#include "common/measure.hpp"
#include "common/rig.hpp"
#include "common/transport/transport.hpp"
#include "tools/logs/log_reader.hpp"
#include "tools/mcap_export/exporter.hpp"

namespace {

namespace lx = ptz::tools::log_exit;

ptz::tools::ExportOptions exportOptions(const ptz::Params& p) {
  ptz::tools::ExportOptions o;
  o.convert.image_rate_hz = p.getDouble("image_rate_hz");
  o.convert.image_max_width_px = p.getInt("image_max_width_px");
  o.convert.jpeg_quality = p.getInt("jpeg_quality");
  o.convert.cloud_rate_hz = p.getDouble("cloud_rate_hz");
  o.convert.channel_prefix = p.getString("channel_prefix");
  const std::string compression = p.getString("compression");
  if (compression != "zstd" && compression != "none") {
    throw p.invalid("compression", "must be zstd or none");
  }
  o.writer.compression = compression == "none" ? "" : compression;
  o.writer.chunk_size_bytes = static_cast<size_t>(p.getInt("chunk_size_kb")) * 1024;
  o.target_class = p.getString("target_class");
  o.settle_s = p.getDouble("settle_s");
  return o;
}

void printTotals(const ptz::tools::McapExporter& e, const std::string& out) {
  std::printf("wrote %s: %llu bytes, %lld LCM messages in\n", out.c_str(),
              static_cast<unsigned long long>(e.bytesWritten()),
              static_cast<long long>(e.messagesIn()));
  for (const auto& [topic, n] : e.written()) {
    std::printf("  %-28s %lld\n", topic.c_str(), static_cast<long long>(n));
  }
  for (const auto& [why, n] : e.converter().dropped()) {
    std::fprintf(stderr, "ptz-mcap: dropped %lld: %s\n", static_cast<long long>(n), why.c_str());
  }
  for (const auto& [channel, n] : e.converter().ignored()) {
    std::printf("  (not shown) %-20s %lld\n", channel.c_str(), static_cast<long long>(n));
  }
}

int exportLog(const ptz::Params& p, const std::string& out) {
  const std::string path = p.getString("log");
  ptz::tools::LogReader log(path);
  ptz::tools::OutputFile file(out);
  ptz::tools::McapExporter exporter(file.tempPath(), ptz::rigFromParams(p), exportOptions(p));
  while (const lcm::LogEvent* ev = log.next()) {
    exporter.add(ev->channel, ev->data, static_cast<size_t>(ev->datalen), ev->timestamp);
  }
  log.requireEvents();
  if (!log.breaks().empty()) {
    std::fprintf(stderr, "ptz-mcap: warning: the log is damaged; exported as far as it reads:\n%s",
                 log.describeBreaks().c_str());
  }
  exporter.finish({{"source_log", path}, {"damaged", log.breaks().empty() ? "no" : "yes"}});
  file.commit();
  printTotals(exporter, out);
  return lx::kOk;
}

// Live: every channel, until SIGINT/SIGTERM or duration_s; what it took in its status.
class LiveRecorder {
 public:
  LiveRecorder(lcm::LCM* lcm, ptz::tools::McapExporter* exporter, ptz::StatusReporter* status)
      : exporter_(exporter), status_(status) {
    lcm->subscribe(".*", &LiveRecorder::handle, this);
  }
  void handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    // Channel names come from the network: a bounded number of them in the status.
    if (counted_.count(channel) || (counted_.size() < 64 && channel.size() <= 64)) {
      counted_.insert(channel);
      status_->countIn(channel, -1);
    } else {
      status_->increment("messages_on_uncounted_channels");
    }
    exporter_->add(channel, rbuf->data, rbuf->data_size, rbuf->recv_utime);
    if (channel != status_->channelName()) ++heard_;
  }
  // Messages heard besides its own status.
  int64_t heard() const { return heard_; }
  void report() {
    status_->setCounter("mcap_bytes", static_cast<int64_t>(exporter_->bytesWritten()));
    int64_t dropped = 0;
    for (const auto& entry : exporter_->converter().dropped()) dropped += entry.second;
    status_->setCounter("dropped_unconvertible", dropped);
  }

 private:
  ptz::tools::McapExporter* exporter_;
  ptz::StatusReporter* status_;
  std::set<std::string> counted_;
  int64_t heard_ = 0;
};

int recordLive(const ptz::Params& p, const std::string& out) {
  const std::string url = ptz::lcmUrl(p);
  ptz::warnIfReceiveBufferSmall(url);
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "ptz-mcap: cannot open LCM at '%s' (scripts/check-network says why)\n",
                 url.c_str());
    return lx::kFailed;
  }
  ptz::StopFlag::install();
  ptz::tools::OutputFile file(out);
  ptz::tools::McapExporter exporter(file.tempPath(), ptz::rigFromParams(p), exportOptions(p));
  ptz::StatusReporter status(&lcm, p, "ptz-mcap");
  LiveRecorder recorder(&lcm, &exporter, &status);
  status.publishNow();  // a sign that it listens, before the first message
  const double duration_s = p.getDouble("duration_s");
  const int64_t start_utime = ptz::wallUtime();
  while (!ptz::StopFlag::stopRequested() &&
         (duration_s <= 0 || (ptz::wallUtime() - start_utime) * 1e-6 < duration_s)) {
    lcm.handleTimeout(100);
    recorder.report();
    status.maybePublish();
  }
  exporter.finish({{"source_lcm_url", url}});
  file.commit();
  recorder.report();
  status.publishLast();
  printTotals(exporter, out);
  if (recorder.heard() == 0) {
    std::fprintf(stderr, "ptz-mcap: heard nothing on '%s' (the file holds only its own status)\n",
                 url.c_str());
    return lx::kNoChannels;
  }
  return lx::kOk;
}

}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz-mcap",
                "Converts an LCM log (--log) or the live traffic (--live) to an MCAP file for "
                "Foxglove, Lichtblick and PlotJuggler (Foxglove's schemas, JSON encoding).\n" +
                    ptz::tools::logExitCodesHelp("") + " (--live: 7 also when nothing was heard)");
  ptz::addTransportParams(p);
  p.add("log", "", "the LCM log to convert (or --live)");
  p.add("live", false, "record the live LCM traffic instead, until Ctrl-C or duration_s");
  p.add("duration_s", 0.0, "s", "--live: stop after this long; 0: at Ctrl-C",
        ptz::Range::atLeast(0));
  p.add("out", "", "the MCAP file to write (required)");
  ptz::declareRigParams(p);
  p.add("image_rate_hz", 0.0, "Hz",
        "images (with calibration and detections) at most this "
        "often by capture time; 0: every frame",
        ptz::Range::atLeast(0));
  p.add("image_max_width_px", 0, "px", "scale wider images down to this width; 0: as they are",
        ptz::Range::atLeast(0));
  p.add("jpeg_quality", 80, "", "JPEG quality of raw frames and scaled images",
        ptz::Range::between(1, 100));
  p.add("cloud_rate_hz", 0.0, "Hz", "POINT_CLOUD at most this often; 0: every cloud",
        ptz::Range::atLeast(0));
  p.add("compression", "zstd", "chunk compression: zstd or none");
  p.add("chunk_size_kb", 4096, "KiB", "chunk size (seeking reads a chunk)",
        ptz::Range::between(64, 1 << 20));
  p.add("target_class", "red_ball", "class of the tracked object (for the run's numbers)");
  p.add("settle_s", 2.0, "s", "centring is measured after this much time from the first frame",
        ptz::Range::atLeast(0));
  try {
    if (!p.parse(argc, argv)) return lx::kOk;
    const std::string out = p.getString("out");
    if (out.empty()) throw ptz::ConfigError("--out FILE is required");
    const bool live = p.getBool("live");
    if (live == !p.getString("log").empty()) {
      throw ptz::ConfigError("give either --log FILE or --live true");
    }
    return live ? recordLive(p, out) : exportLog(p, out);
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-mcap: %s\n", e.what());
    return lx::kUsage;
  } catch (const ptz::tools::LogError& e) {
    std::fprintf(stderr, "ptz-mcap: %s\n", e.what());
    return e.exitCode();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptz-mcap: stopped: %s\n", e.what());
    return lx::kFailed;
  }
}
