// The closed loop in real time across processes (ptz-sim + ptz-detect + ptz-control, ptz-depth
// beside at lower priority), JPEG frames, at VGA@30, VGA@60 and 1080p@30: per frame, the
// readout (capture -> STEREO_FRAME publish: the simulator's render and encode), frame publish ->
// pose publish (ptz-detect), frame publish -> setpoint publish (the chain), capture -> setpoint
// publish; the same frames' LCM delivery to this listener is the run's baseline. Counts frames
// skipped late by the simulator and frames ptz-detect never answered. Prints a "ROW" line per
// run for scripts/bench's table. Run inside a private network namespace (scripts/bench does).
#include <sys/resource.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/sim_recording.hpp"

using namespace std::chrono_literals;

namespace {

struct FrameTimes {
  int64_t capture_utime = 0, publish_utime = 0, received_utime = 0;
  int64_t pose_utime = 0, setpoint_utime = 0;
};

struct Listener {
  std::map<int64_t, FrameTimes> frames;  // by seq
  std::map<std::string, std::map<std::string, int64_t>> counters;
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    FrameTimes& f = frames[m->seq];
    f.capture_utime = m->utime;
    f.publish_utime = m->publish_utime;
    f.received_utime = ptz::wallUtime();
  }
  void onPose(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::object_pose_t* m) {
    frames[m->frame_seq].pose_utime = m->publish_utime;
  }
  void onSetpoint(const lcm::ReceiveBuffer*, const std::string&,
                  const ptzstereo::ptz_setpoint_t* m) {
    frames[m->frame_seq].setpoint_utime = m->publish_utime;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    counters[m->process]["up"] = 1;
    for (const auto& c : m->counters) counters[m->process][c.name] = c.value;
    for (const auto& c : m->channels) counters[m->process]["messages:" + c.channel] = c.messages;
  }
};

struct Run {
  std::string name, image_size = "vga", priority = "nice", loop_priority = "normal", csv_dir;
  double rate_hz = 30, seconds = 60;
  bool depth = true;
  std::string recording;  // a folder of writeSimRecording played by ptz-camera, else ptz-sim
  std::vector<std::string> detect_flags;
  std::string sim_config = PTZ_SOURCE_DIR "/config/sim_default.yaml";
};

struct Series {
  std::vector<double> readout, detect, chain, loop, delivery;
};

void line(const char* what, const std::vector<double>& v) {
  std::printf("  %-46s median %7.2f ms   p99 %7.2f ms   (n = %zu)\n", what, ptz::percentile(v, 50),
              ptz::percentile(v, 99), v.size());
}

std::string cell(const std::vector<double>& v) {
  char s[48];
  std::snprintf(s, sizeof s, "%.1f / %.1f", ptz::percentile(v, 50), ptz::percentile(v, 99));
  return s;
}

std::vector<std::string> withPriority(const std::string& priority, std::vector<std::string> argv) {
  if (priority == "fifo") argv.insert(argv.begin(), {"/usr/bin/chrt", "--fifo", "10"});
  if (priority == "high") argv.insert(argv.begin(), {"/usr/bin/nice", "-n", "-10"});
  if (priority == "idle") argv.insert(argv.begin(), {"/usr/bin/chrt", "--idle", "0"});
  if (priority == "nice") argv.insert(argv.begin(), {"/usr/bin/nice", "-n", "19"});
  return argv;
}

// False when a process never came up or no frame was answered: nothing to report then.
bool run(const Run& r) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Listener l;
  lcm.subscribe("STEREO_FRAME", &Listener::onFrame, &l);
  lcm.subscribe("OBJECT_POSE", &Listener::onPose, &l);
  lcm.subscribe("PTZ_SETPOINT", &Listener::onSetpoint, &l);
  lcm.subscribe("PROCESS_STATUS_.*", &Listener::onStatus, &l);
  const std::string url = ptz::test::kTestUrl;
  std::vector<std::string> detect_argv = {
      PTZ_DETECT_BIN, "--lcm-url", url, "--config", PTZ_SOURCE_DIR "/config/detect_default.yaml",
      "--image-size", r.image_size};
  detect_argv.insert(detect_argv.end(), r.detect_flags.begin(), r.detect_flags.end());
  ptz::test::ChildProcess detect(withPriority(r.loop_priority, detect_argv));
  ptz::test::ChildProcess control(withPriority(
      r.loop_priority, {PTZ_CONTROL_BIN, "--lcm-url", url, "--image-size", r.image_size}));
  std::unique_ptr<ptz::test::ChildProcess> depth;
  if (r.depth) {
    depth = std::make_unique<ptz::test::ChildProcess>(
        withPriority(r.priority, {PTZ_DEPTH_BIN, "--lcm-url", url, "--image-size", r.image_size,
                                  "--follow-target", "false", "--cloud-preview-rate-hz", "0"}));
  }
  if (!ptz::test::handleUntil(
          lcm,
          [&] {
            return l.counters["ptz-detect"]["up"] && l.counters["ptz-control"]["up"] &&
                   (!r.depth || l.counters["ptz-depth"]["up"]);
          },
          20s)) {
    std::fprintf(stderr, "ptz_bench_loop: %s: ptz-detect, ptz-control or ptz-depth never came up\n",
                 r.name.c_str());
    return false;
  }
  std::vector<std::string> source_argv = r.recording.empty()
                                             ? std::vector<std::string>{PTZ_SIM_BIN,
                                                                        "--lcm-url",
                                                                        url,
                                                                        "--config",
                                                                        r.sim_config,
                                                                        "--encoding",
                                                                        "jpeg",
                                                                        "--image-size",
                                                                        r.image_size,
                                                                        "--frame-rate-hz",
                                                                        std::to_string(r.rate_hz),
                                                                        "--duration-s",
                                                                        std::to_string(r.seconds),
                                                                        "--status-period-s",
                                                                        "0.5"}
                                             : std::vector<std::string>{PTZ_CAMERA_BIN,
                                                                        "--lcm-url",
                                                                        url,
                                                                        "--left-source",
                                                                        r.recording + "/left",
                                                                        "--right-source",
                                                                        r.recording + "/right",
                                                                        "--width",
                                                                        "1920",
                                                                        "--height",
                                                                        "1080",
                                                                        "--encoding",
                                                                        "jpeg",
                                                                        "--loop",
                                                                        "true",
                                                                        "--status-period-s",
                                                                        "0.5"};
  ptz::test::ChildProcess source(withPriority(r.loop_priority, source_argv));
  if (r.recording.empty()) {
    ptz::test::handleUntil(
        lcm, [&] { return source.wait(0ms) >= 0; }, std::chrono::seconds(int(r.seconds) + 60));
  } else {  // a looped recording plays until stopped
    const int64_t end_utime = ptz::wallUtime() + static_cast<int64_t>(r.seconds * 1e6);
    ptz::test::handleUntil(
        lcm, [&] { return ptz::wallUtime() >= end_utime; },
        std::chrono::seconds(int(r.seconds) + 60));
    source.stop();
  }
  ptz::test::drain(lcm, 300ms);

  Series s;
  int64_t unanswered = 0;
  FILE* csv =
      r.csv_dir.empty() ? nullptr : std::fopen((r.csv_dir + "/" + r.name + ".csv").c_str(), "w");
  if (csv)
    std::fprintf(csv, "seq,capture_utime,publish_utime,received_utime,pose_utime,setpoint_utime\n");
  // A recording's capture times are its own (the past): its schedule on the wall clock is taken
  // as the earliest publish less capture of the run, and readout counts from there.
  int64_t schedule_us = 0;
  if (!r.recording.empty()) {
    schedule_us = INT64_MAX;
    for (const auto& [seq, f] : l.frames) {
      if (f.publish_utime) schedule_us = std::min(schedule_us, f.publish_utime - f.capture_utime);
    }
  }
  for (auto& [seq, f] : l.frames) {
    f.capture_utime += schedule_us;
    if (csv)
      std::fprintf(csv, "%lld,%lld,%lld,%lld,%lld,%lld\n", (long long)seq,
                   (long long)f.capture_utime, (long long)f.publish_utime,
                   (long long)f.received_utime, (long long)f.pose_utime,
                   (long long)f.setpoint_utime);
    if (f.publish_utime == 0) continue;  // a pose of a frame this listener missed
    s.readout.push_back((f.publish_utime - f.capture_utime) / 1000.0);
    s.delivery.push_back((f.received_utime - f.publish_utime) / 1000.0);
    if (f.pose_utime == 0) ++unanswered;
    if (f.pose_utime) s.detect.push_back((f.pose_utime - f.publish_utime) / 1000.0);
    if (f.setpoint_utime) {
      s.chain.push_back((f.setpoint_utime - f.publish_utime) / 1000.0);
      s.loop.push_back((f.setpoint_utime - f.capture_utime) / 1000.0);
    }
  }
  if (csv) std::fclose(csv);
  auto& c = l.counters;
  const int64_t published = r.recording.empty() ? c["ptz-sim"]["frames_published"]
                                                : c["ptz-camera"]["messages:STEREO_FRAME"];
  const int64_t skipped = c["ptz-sim"]["frames_skipped_late"];
  if (published == 0 || s.chain.empty()) {
    std::fprintf(stderr, "ptz_bench_loop: %s: %lld frames published, %zu answered: no numbers\n",
                 r.name.c_str(), static_cast<long long>(published), s.chain.size());
    return false;
  }
  const int64_t depth_frames = c["ptz-depth"]["frames_processed"];
  // A recording is not rendered: its readout is its lateness against its schedule, and nothing
  // is skipped late by a simulator.
  const bool rec = !r.recording.empty();
  char skipped_cell[64];
  std::snprintf(skipped_cell, sizeof skipped_cell, "%lld of %lld", static_cast<long long>(skipped),
                static_cast<long long>(published + skipped));
  std::printf("%s: %s at %.0f Hz, %.0f s realtime from %s, JPEG, ptz-depth %s:\n", r.name.c_str(),
              r.image_size.c_str(), r.rate_hz, r.seconds,
              r.recording.empty() ? "ptz-sim" : "a recording played by ptz-camera",
              r.depth ? ("beside (" + r.priority + ")").c_str() : "off");
  line(rec ? "schedule -> STEREO_FRAME publish (lateness)"
           : "capture -> STEREO_FRAME publish (render, encode)",
       s.readout);
  line("STEREO_FRAME publish -> OBJECT_POSE publish", s.detect);
  line("STEREO_FRAME publish -> setpoint publish (chain)", s.chain);
  line("capture -> setpoint publish", s.loop);
  line("baseline: STEREO_FRAME publish -> received here", s.delivery);
  std::printf(
      "  frames published %lld, skipped late by ptz-sim %lld, received here %zu, not "
      "answered by ptz-detect %lld; ptz-depth processed %lld\n",
      static_cast<long long>(published), static_cast<long long>(skipped), s.readout.size(),
      static_cast<long long>(unanswered), static_cast<long long>(depth_frames));
  auto& d = c["ptz-detect"];
  std::printf(
      "  ptz-detect's own last status: processing p50 %.2f p99 %.2f ms, box yaws p50 %.2f "
      "p99 %.2f ms (%lld), frames scanned whole %lld, windowed %lld\n",
      d["processing_us_p50"] / 1e3, d["processing_us_p99"] / 1e3, d["orientation_us_p50"] / 1e3,
      d["orientation_us_p99"] / 1e3, static_cast<long long>(d["orientations_estimated"]),
      static_cast<long long>(d["frames_scanned_full"]),
      static_cast<long long>(d["frames_scanned_windowed"]));
  std::printf("ROW | %s | %s, depth %s | %s%s | %s | %s | %s | %s | %s | %lld of %lld | %lld |\n",
              r.name.c_str(), r.loop_priority.c_str(), r.depth ? r.priority.c_str() : "off",
              rec ? "lateness " : "", cell(s.readout).c_str(), cell(s.detect).c_str(),
              cell(s.chain).c_str(), cell(s.loop).c_str(), cell(s.delivery).c_str(),
              rec ? "— (a recording)" : skipped_cell, static_cast<long long>(unanswered),
              static_cast<long long>(published), static_cast<long long>(depth_frames));
  std::fflush(stdout);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz_bench_loop", "The closed loop in real time across processes.");
  p.add("runs", "vga30,vga60,1080p30,1080p30-rec,1080p30-rec-480,vga30-markers,vga30-people",
        "comma-separated runs: vga30, vga60, 1080p30 (the simulator rendering 1080p), "
        "1080p30-rec (a recording of it, one period of the ball's path, played in a loop by "
        "ptz-camera), 1080p30-rec-480 "
        "(the same, ptz-detect's full scans on the image reduced to 480 px), vga30-markers, "
        "1080p30-markers (config/sim_markers.yaml: the tagged cube followed by its tags, with "
        "config/markers_tool.yaml), vga30-people (config/sim_people.yaml: the walking figure "
        "followed, a face and a person class of config/people.yaml)");
  p.add("seconds", 60.0, "s", "realtime duration of each run", ptz::Range::between(1, 3600));
  p.add("depth", true, "ptz-depth beside the loop");
  p.add("depth_priority", "nice", "ptz-depth's priority: nice (19) or idle (SCHED_IDLE)");
  p.add("loop_priority", "normal",
        "ptz-sim's, ptz-detect's and ptz-control's priority: normal or fifo (SCHED_FIFO 10)");
  p.add("detect_flags", "", "more flags for ptz-detect, separated by spaces (to compare settings)");
  p.add("csv_dir", "", "folder for a CSV of each run's per-frame times (empty: none)");
  if (!p.parse(argc, argv)) return 0;
  std::string runs = p.getString("runs");
  // The 1080p runs' recording, made once: one period of the ball's path, so that the loop goes on
  // without a jump (a jump is a lost target and full scans, which a camera never shows).
  std::string recording;
  const auto record = [&recording]() -> bool {
    if (!recording.empty()) return true;
    char dir[] = "/tmp/ptz_bench_loop_XXXXXX";
    if (!mkdtemp(dir)) return false;
    recording = dir;
    const char* config = PTZ_SOURCE_DIR "/config/sim_default.yaml";
    const int frames = static_cast<int>(std::lround(ptz::test::simBallPeriodS(config) * 30.0));
    const auto rec = ptz::test::writeSimRecording(recording, config, "1080p", frames, 30.0, 90);
    std::printf("recorded %d stereo frames at 1080p in %s (the ball in both images in %d)\n",
                frames, dir, rec.frames_ball_visible);
    return true;
  };
  for (size_t start = 0; start <= runs.size();) {
    const size_t comma = std::min(runs.find(',', start), runs.size());
    const std::string name = runs.substr(start, comma - start);
    start = comma + 1;
    Run r;
    r.name = name;
    r.seconds = p.getDouble("seconds");
    r.depth = p.getBool("depth");
    r.priority = p.getString("depth_priority");
    r.csv_dir = p.getString("csv_dir");
    r.loop_priority = p.getString("loop_priority");
    std::istringstream flags(p.getString("detect_flags"));
    for (std::string f; flags >> f;) r.detect_flags.push_back(f);
    if (name == "vga30") {
    } else if (name == "vga60") {
      r.rate_hz = 60;
    } else if (name == "vga30-markers" || name == "1080p30-markers") {
      if (name[0] == '1') r.image_size = "1080p";
      r.sim_config = PTZ_SOURCE_DIR "/config/sim_markers.yaml";
      r.detect_flags.insert(r.detect_flags.end(),
                            {"--markers-config", PTZ_SOURCE_DIR "/config/markers_tool.yaml",
                             "--target-class", "tool"});
    } else if (name == "vga30-people") {
      r.sim_config = PTZ_SOURCE_DIR "/config/sim_people.yaml";
      r.detect_flags.insert(
          r.detect_flags.end(),
          {"--people-config", PTZ_SOURCE_DIR "/config/people.yaml", "--target-class", "person"});
    } else if (name == "1080p30") {
      r.image_size = "1080p";
    } else if (name == "1080p30-rec" || name == "1080p30-rec-480") {
      if (name == "1080p30-rec-480")
        r.detect_flags.insert(r.detect_flags.end(), {"--full-scan-max-width-px", "480"});
      r.image_size = "1080p";
      if (!record()) return 1;
      r.recording = recording;
    } else {
      std::fprintf(stderr, "ptz_bench_loop: unknown run '%s'\n", name.c_str());
      return 2;
    }
    if (!run(r)) {
      if (!recording.empty()) std::filesystem::remove_all(recording);
      return 1;
    }
  }
  if (!recording.empty()) std::filesystem::remove_all(recording);
  return 0;
}
