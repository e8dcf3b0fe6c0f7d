// The closed loop in real time at 30 Hz across processes (ptz-sim + ptz-detect + ptz-control),
// raw and JPEG frames: frame capture -> pose publish and -> setpoint publish latency (median,
// p99), the simulator's own capture -> frame publish share (its render is the simulated
// camera's readout), frame publish -> setpoint publish (the processing chain), and frames
// processed / published; each with ptz-detect's windows (perception/detect/windows.hpp) off and
// on.
// Run inside a private network namespace (scripts/bench does).
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "common/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;

namespace {

struct Listener {
  std::vector<double> pose_ms, setpoint_ms, frame_publish_ms, chain_ms;
  std::map<int64_t, int64_t> frame_published_utime;  // seq -> publish_utime
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    frame_published_utime[m->seq] = m->publish_utime;
  }
  std::map<std::string, std::map<std::string, int64_t>> counters;
  void onPose(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::object_pose_t* m) {
    pose_ms.push_back((m->publish_utime - m->utime) / 1000.0);
  }
  void onSetpoint(const lcm::ReceiveBuffer*, const std::string&,
                  const ptzstereo::ptz_setpoint_t* m) {
    setpoint_ms.push_back((m->publish_utime - m->utime) / 1000.0);
    auto it = frame_published_utime.find(m->frame_seq);
    if (it != frame_published_utime.end())
      chain_ms.push_back((m->publish_utime - it->second) / 1000.0);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    counters[m->process]["up"] = 1;
    for (const auto& c : m->counters) counters[m->process][c.name] = c.value;
    for (const auto& c : m->channels) {
      if (m->process == "ptz-sim" && c.channel == "STEREO_FRAME" &&
          std::isfinite(c.latency_ms_p50)) {
        frame_publish_ms.push_back(c.latency_ms_p50);
      }
    }
  }
};

void report(const char* what, const std::vector<double>& v) {
  std::printf("  %-44s median %7.2f ms   p99 %7.2f ms\n", what, ptz::percentile(v, 50),
              ptz::percentile(v, 99));
}

void run(const std::string& encoding, bool windows) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Listener l;
  lcm.subscribe("STEREO_FRAME", &Listener::onFrame, &l);
  lcm.subscribe("OBJECT_POSE", &Listener::onPose, &l);
  lcm.subscribe("PTZ_SETPOINT", &Listener::onSetpoint, &l);
  lcm.subscribe("PROCESS_STATUS_.*", &Listener::onStatus, &l);
  ptz::test::ChildProcess detect({PTZ_DETECT_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                                  PTZ_SOURCE_DIR "/config/detect_default.yaml", "--windows",
                                  windows ? "true" : "false"});
  ptz::test::ChildProcess control({PTZ_CONTROL_BIN, "--lcm-url", ptz::test::kTestUrl});
  ptz::test::handleUntil(
      lcm, [&] { return l.counters["ptz-detect"]["up"] && l.counters["ptz-control"]["up"]; }, 20s);
  ptz::test::ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                               PTZ_SOURCE_DIR "/config/sim_default.yaml", "--frames", "600",
                               "--encoding", encoding, "--status-period-s", "0.5"});
  ptz::test::handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0; }, 60s);
  ptz::test::drain(lcm, 300ms);
  const int64_t published = l.counters["ptz-sim"]["frames_published"];
  std::printf("%s frames, windows %s, 20 s at 30 Hz:\n", encoding.c_str(), windows ? "on" : "off");
  report("capture -> setpoint publish (the loop)", l.setpoint_ms);
  report("capture -> OBJECT_POSE publish", l.pose_ms);
  report("capture -> STEREO_FRAME publish (sim, per 0.5 s)", l.frame_publish_ms);
  report("STEREO_FRAME publish -> setpoint publish", l.chain_ms);
  std::printf("  frames processed / published                  %zu / %lld = %.1f %%\n",
              l.pose_ms.size(), static_cast<long long>(published),
              published ? 100.0 * l.pose_ms.size() / published : 0.0);
  auto& d = l.counters["ptz-detect"];
  std::printf("  ptz-detect frames scanned windowed / whole        %lld / %lld\n",
              static_cast<long long>(d["frames_scanned_windowed"]),
              static_cast<long long>(d["frames_scanned_full"]));
}

}  // namespace

int main() {
  for (const char* encoding : {"raw", "jpeg"}) {
    run(encoding, false);
    run(encoding, true);
  }
  return 0;
}
