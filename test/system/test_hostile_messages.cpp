// The closed loop (ptz-sim, ptz-detect, ptz-control, ptz-depth as processes) under a stream of
// hostile messages on every channel they subscribe to: random bytes, truncated messages and
// well-formed messages with hostile values. No process dies, the loop never stalls, memory stays
// bounded, every message each process received is counted (in, or dropped with a reason), and no
// head state is non-finite or beyond a limit.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <set>

#include "common/plant.hpp"
#include "common/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;
using ptz::test::kTestUrl;

namespace {

const std::vector<std::string> kChannels = {"STEREO_FRAME", "OBJECT_POSE", "PTZ_SETPOINT",
                                            "PTZ_STATE"};
// Who subscribes to what: every one of these counts every message it received.
const std::map<std::string, std::vector<std::string>> kSubscribers = {
    {"ptz-sim", {"PTZ_SETPOINT"}},
    {"ptz-detect", {"STEREO_FRAME"}},
    {"ptz-control", {"OBJECT_POSE", "PTZ_STATE"}},
    {"ptz-depth", {"STEREO_FRAME", "OBJECT_POSE"}}};

int64_t procStatusKb(pid_t pid, const std::string& key) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string k;
  int64_t value = -1;
  while (in >> k) {
    if (k == key + ":") {
      in >> value;
      break;
    }
  }
  return value;
}

struct Listener {
  std::map<std::string, int64_t> on_wire;  // every message on each channel, as this test saw it
  std::map<std::string, ptzstereo::process_status_t> status;
  std::vector<int64_t> setpoint_arrivals_utime;  // ptz-control's own, not ours
  std::set<uint64_t> ours;                       // hashes of the hostile setpoints we sent
  int64_t bad_states = 0, states = 0;
  ptz::PtzPlant::Params limits = ptz::defaultPlantParams();

  void onAny(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    ++on_wire[channel];
    if (channel == "PTZ_SETPOINT") {
      const auto* b = static_cast<const uint8_t*>(rbuf->data);
      if (!ours.count(ptz::test::fnv1a(std::vector<uint8_t>(b, b + rbuf->data_size)))) {
        setpoint_arrivals_utime.push_back(ptz::wallUtime());
      }
    }
    if (channel == "PTZ_STATE") {
      ptzstereo::ptz_state_t s;
      // The simulator's states decode; ours (hostile) may not and do not count here.
      if (!ptz::decodeChecked(rbuf->data, rbuf->data_size, &s, nullptr) || s.utime == 42) return;
      ++states;
      for (const auto* h : {&s.left, &s.right}) {
        const bool ok = std::isfinite(h->pan_rad) && std::isfinite(h->tilt_rad) &&
                        std::isfinite(h->zoom) &&
                        h->pan_rad >= limits.axis[0].min_position - 1e-9 &&
                        h->pan_rad <= limits.axis[0].max_position + 1e-9 &&
                        h->tilt_rad >= limits.axis[1].min_position - 1e-9 &&
                        h->tilt_rad <= limits.axis[1].max_position + 1e-9 &&
                        h->zoom >= limits.axis[2].min_position - 1e-9 &&
                        h->zoom <= limits.axis[2].max_position + 1e-9;
        if (!ok) ++bad_states;
      }
    }
  }
  void onStatus(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    ptzstereo::process_status_t m;
    if (ptz::decodeChecked(rbuf->data, rbuf->data_size, &m, nullptr)) status[m.process] = m;
  }
  // What a process counted on a channel: in, plus dropped for any reason but seq_gap (a gap
  // counts frames that never arrived).
  int64_t counted(const std::string& process, const std::string& channel) const {
    auto it = status.find(process);
    if (it == status.end()) return -1;
    int64_t n = 0;
    for (const auto& c : it->second.channels) {
      if (c.channel == channel && c.direction == ptzstereo::channel_status_t::DIRECTION_IN) {
        n += c.messages;
      }
    }
    for (const auto& c : it->second.counters) {
      const std::string prefix = channel + ".dropped_";
      if (c.name.rfind(prefix, 0) == 0 && c.name != prefix + "seq_gap") n += c.value;
    }
    return n;
  }
};

// Hostile messages: a third random bytes, a third truncated real encodings, a third well-formed
// with hostile values (non-finite numbers, extreme times and counts, wrong formats).
class Hostile {
 public:
  explicit Hostile(uint32_t seed) : rng_(seed) {}

  std::vector<uint8_t> make(const std::string& channel) {
    const int kind = static_cast<int>(rng_() % 3);
    if (kind == 0) {
      std::vector<uint8_t> b(1 + rng_() % 3000);
      for (auto& x : b) x = static_cast<uint8_t>(rng_());
      return b;
    }
    std::vector<uint8_t> b = wellFormed(channel);
    if (kind == 1) b.resize(rng_() % b.size());
    return b;
  }

 private:
  double hostileNumber() {
    const double values[] = {std::nan(""), INFINITY, -INFINITY, 1e300, -1e300, 0.0, 3.0};
    return values[rng_() % 7];
  }
  int64_t hostileTime() {
    const int64_t now = ptz::wallUtime();
    const int64_t values[] = {std::numeric_limits<int64_t>::min(),
                              std::numeric_limits<int64_t>::max(),
                              0,
                              now + 3'600'000'000,
                              now - 3'600'000'000,
                              now};
    return values[rng_() % 6];
  }
  template <class Msg>
  static std::vector<uint8_t> bytes(const Msg& m) {
    std::vector<uint8_t> b(static_cast<size_t>(m.getEncodedSize()));
    m.encode(b.data(), 0, static_cast<int>(b.size()));
    return b;
  }
  std::vector<uint8_t> wellFormed(const std::string& channel) {
    if (channel == "STEREO_FRAME") {
      ptzstereo::stereo_frame_t f{};
      f.utime = hostileTime();
      f.publish_utime = hostileTime();
      f.seq = static_cast<int64_t>(rng_()) * 1000;
      for (auto* im : {&f.left, &f.right}) {
        im->width = static_cast<int32_t>(rng_() % 2) ? 640 : static_cast<int32_t>(rng_());
        im->height = 480;
        im->row_stride = 640 * 3;
        im->pixel_format = static_cast<int8_t>(rng_() % 5);
        im->encoding = static_cast<int8_t>(rng_() % 3);
        im->pan_rad = hostileNumber();
        im->zoom = 1;
        im->data.assign(rng_() % 1000, 0xFF);
        im->data_size = static_cast<int32_t>(im->data.size());
      }
      return bytes(f);
    }
    if (channel == "OBJECT_POSE") {
      ptzstereo::object_pose_t p{};
      p.utime = hostileTime();
      p.publish_utime = hostileTime();
      p.frame_seq = static_cast<int64_t>(rng_());
      p.left_ptz = {hostileNumber(), 0, 1};
      p.right_ptz = {0, hostileNumber(), 1};
      p.objects.resize(rng_() % 4);
      for (auto& o : p.objects) {
        o.class_name = "red_ball";
        for (double& v : o.position_m) v = hostileNumber();
        for (double& v : o.covariance_m2) v = hostileNumber();
        o.radius_m = hostileNumber();
      }
      p.num_objects = static_cast<int32_t>(p.objects.size());
      p.target_index = static_cast<int32_t>(rng_() % 6) - 1;
      return bytes(p);
    }
    if (channel == "PTZ_SETPOINT") {
      ptzstereo::ptz_setpoint_t s{};
      s.utime = hostileTime();
      s.publish_utime = hostileTime();
      s.frame_seq = static_cast<int64_t>(rng_());
      s.left = {hostileNumber(), hostileNumber(), hostileNumber()};
      s.right = {hostileNumber(), hostileNumber(), hostileNumber()};
      return bytes(s);
    }
    ptzstereo::ptz_state_t st{};
    st.utime = 42;  // marks ours
    st.publish_utime = hostileTime();
    st.left = {hostileNumber(), hostileNumber(), hostileNumber(), 0, 0, 0, true};
    return bytes(st);
  }

  std::mt19937 rng_;
};

}  // namespace

TEST(HostileMessages, TheLoopHoldsAndCountsEverything) {
  lcm::LCM lcm(kTestUrl);
  Listener l;
  for (const auto& ch : kChannels) lcm.subscribe(ch, &Listener::onAny, &l);
  lcm.subscribe("PROCESS_STATUS_.*", &Listener::onStatus, &l);
  const std::string status_period = "0.2";
  std::map<std::string, std::unique_ptr<ChildProcess>> procs;
  procs["ptz-detect"] = std::make_unique<ChildProcess>(std::vector<std::string>{
      PTZ_DETECT_BIN, "--lcm-url", kTestUrl, "--config",
      PTZ_SOURCE_DIR "/config/detect_default.yaml", "--status-period-s", status_period});
  procs["ptz-control"] = std::make_unique<ChildProcess>(std::vector<std::string>{
      PTZ_CONTROL_BIN, "--lcm-url", kTestUrl, "--status-period-s", status_period});
  procs["ptz-depth"] = std::make_unique<ChildProcess>(std::vector<std::string>{
      PTZ_DEPTH_BIN, "--lcm-url", kTestUrl, "--status-period-s", status_period});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] {
        return l.status.count("ptz-detect") && l.status.count("ptz-control") &&
               l.status.count("ptz-depth");
      },
      30s));
  procs["ptz-sim"] = std::make_unique<ChildProcess>(std::vector<std::string>{
      PTZ_SIM_BIN, "--lcm-url", kTestUrl, "--clock", "realtime", "--encoding", "jpeg", "--config",
      PTZ_SOURCE_DIR "/config/sim_default.yaml", "--status-period-s", status_period});
  // Warm: the loop runs.
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.setpoint_arrivals_utime.size() > 60; }, 30s));
  std::map<std::string, int64_t> rss_start_kb;
  for (const auto& [name, p] : procs) {
    rss_start_kb[name] = procStatusKb(p->pid(), "VmRSS");
    ASSERT_GT(rss_start_kb[name], 0) << name;
  }

  // 20 s of hostile traffic, 40 messages a second on each channel.
  Hostile hostile(2026);
  std::map<std::string, int64_t> sent;
  const size_t loop_start = l.setpoint_arrivals_utime.size();
  const auto end = std::chrono::steady_clock::now() + 20s;
  auto next = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() < end) {
    for (const auto& ch : kChannels) {
      const std::vector<uint8_t> b = hostile.make(ch);
      if (ch == "PTZ_SETPOINT") l.ours.insert(ptz::test::fnv1a(b));
      lcm.publish(ch, b.data(), static_cast<unsigned>(b.size()));
      ++sent[ch];
    }
    next += 25ms;
    while (std::chrono::steady_clock::now() < next) {
      lcm.handleTimeout(static_cast<int>(std::max<int64_t>(
          1, std::chrono::duration_cast<std::chrono::milliseconds>(next -
                                                                   std::chrono::steady_clock::now())
                 .count())));
    }
  }
  const size_t loop_end = l.setpoint_arrivals_utime.size();
  // The loop's output: the longest silence between two of ptz-control's setpoints.
  int64_t longest_stall_us = 0;
  for (size_t i = loop_start + 1; i < loop_end; ++i) {
    longest_stall_us =
        std::max(longest_stall_us, l.setpoint_arrivals_utime[i] - l.setpoint_arrivals_utime[i - 1]);
  }
  std::map<std::string, int64_t> rss_peak_kb;
  for (const auto& [name, p] : procs) {
    EXPECT_TRUE(p->running()) << name << " died";
    rss_peak_kb[name] = procStatusKb(p->pid(), "VmHWM");
  }
  // Quiet: freeze the simulator, so that nothing is in flight when the others report.
  kill(procs["ptz-sim"]->pid(), SIGSTOP);
  ptz::test::handleUntil(
      lcm, [] { return false; }, 1500ms);
  const auto frozen_status = l.status;
  const auto frozen_wire = l.on_wire;
  // No more setpoints from the loop; the simulator wakes to what waited for it and reports.
  EXPECT_EQ(procs["ptz-control"]->stop(), 0);
  kill(procs["ptz-sim"]->pid(), SIGCONT);
  EXPECT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counted("ptz-sim", "PTZ_SETPOINT") == l.on_wire["PTZ_SETPOINT"]; }, 5s));
  l.status["ptz-control"] = frozen_status.at("ptz-control");
  l.status["ptz-detect"] = frozen_status.at("ptz-detect");
  l.status["ptz-depth"] = frozen_status.at("ptz-depth");

  for (const auto& ch : kChannels) {
    std::printf("%-13s hostile sent %5lld, on the wire %6lld\n", ch.c_str(),
                static_cast<long long>(sent[ch]), static_cast<long long>(frozen_wire.at(ch)));
  }
  for (const auto& [name, channels] : kSubscribers) {
    for (const auto& ch : channels) {
      const int64_t counted = l.counted(name, ch);
      const int64_t wire = name == "ptz-sim" ? l.on_wire[ch] : frozen_wire.at(ch);
      std::printf("%-11s %-13s counted %6lld of %6lld\n", name.c_str(), ch.c_str(),
                  static_cast<long long>(counted), static_cast<long long>(wire));
      EXPECT_EQ(counted, wire) << name << " on " << ch;
    }
    std::printf("%-11s RSS %lld kB at the start, peak %lld kB\n", name.c_str(),
                static_cast<long long>(rss_start_kb[name]),
                static_cast<long long>(rss_peak_kb[name]));
    EXPECT_LE(rss_peak_kb[name], 2 * rss_start_kb[name]) << name;
  }
  std::printf("setpoints from ptz-control during the attack: %zu, longest gap %.0f ms\n",
              loop_end - loop_start, longest_stall_us / 1000.0);
  EXPECT_GT(loop_end - loop_start, 200u);
  EXPECT_LT(longest_stall_us, 500'000);
  EXPECT_GT(l.states, 1000);
  EXPECT_EQ(l.bad_states, 0);
}
