// The closed loop (ptz-sim, ptz-detect, ptz-control, ptz-depth as processes) under a stream of
// hostile messages on every channel they subscribe to: random bytes, truncated messages and
// well-formed messages with hostile values. No process dies, the loop never stalls (ptz-detect
// keeps answering frames, ptz-control keeps sending setpoints), memory stays bounded, every
// message each process received is counted (in, or dropped with a reason), no hostile target
// request is followed, and no head state is non-finite or beyond a limit.
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
#include "common/transport/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;
using ptz::test::kTestUrl;

namespace {

const std::vector<std::string> kChannels = {"STEREO_FRAME",  "OBJECT_POSE",  "OBJECT_TRACKS",
                                            "TARGET_SELECT", "PTZ_SETPOINT", "PTZ_STATE"};
// Who subscribes to what: every one of these counts every message it received.
const std::map<std::string, std::vector<std::string>> kSubscribers = {
    {"ptz-sim", {"PTZ_SETPOINT"}},
    {"ptz-detect", {"STEREO_FRAME", "TARGET_SELECT"}},
    {"ptz-control", {"OBJECT_TRACKS", "PTZ_STATE"}},
    {"ptz-depth", {"STEREO_FRAME", "OBJECT_POSE"}}};
// Why ptz-detect must drop each hostile TARGET_SELECT: none can be met.
const std::vector<std::string> kSelectReasons = {"undecodable", "stale", "future", "refused"};

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
  std::vector<int64_t> setpoint_arrivals_utime;    // ptz-control's own, not ours
  std::vector<int64_t> tracks_arrivals_utime;      // ptz-detect's own, not ours
  std::map<std::string, std::set<uint64_t>> ours;  // hashes of the hostile messages we sent
  std::map<uint64_t, std::string> select_reason;   // a hostile TARGET_SELECT's drop reason
  std::map<std::string, int64_t> selects_on_wire;  // by the reason they must be dropped for
  int64_t bad_states = 0, states = 0;
  ptz::PtzPlant::Params limits = ptz::defaultPlantParams();

  void onAny(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    ++on_wire[channel];
    if (channel == "PTZ_STATE") {
      checkState(rbuf);
    } else if (channel == "PTZ_SETPOINT" || channel == "OBJECT_TRACKS" ||
               channel == "TARGET_SELECT") {
      whose(rbuf, channel);
    }
  }
  // Ours or a process's (ptz-control's setpoints, ptz-detect's tracks), by the bytes.
  void whose(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    const auto* b = static_cast<const uint8_t*>(rbuf->data);
    const uint64_t hash = ptz::test::fnv1a(std::vector<uint8_t>(b, b + rbuf->data_size));
    const bool mine = ours[channel].count(hash) > 0;
    if (channel == "PTZ_SETPOINT" && !mine) setpoint_arrivals_utime.push_back(ptz::wallUtime());
    if (channel == "OBJECT_TRACKS" && !mine) tracks_arrivals_utime.push_back(ptz::wallUtime());
    if (channel == "TARGET_SELECT") {
      const auto it = select_reason.find(hash);
      ++selects_on_wire[it == select_reason.end() ? "not ours" : it->second];
    }
  }
  void checkState(const lcm::ReceiveBuffer* rbuf) {
    ptzstereo::ptz_state_t s;
    // The simulator's states decode; ours (hostile) may not and do not count here.
    if (!ptz::decodeChecked(rbuf->data, rbuf->data_size, &s, nullptr) || s.utime == 42) return;
    ++states;
    for (const auto* h : {&s.left, &s.right}) {
      const bool ok = std::isfinite(h->pan_rad) && std::isfinite(h->tilt_rad) &&
                      std::isfinite(h->zoom) && h->pan_rad >= limits.axis[0].min_position - 1e-9 &&
                      h->pan_rad <= limits.axis[0].max_position + 1e-9 &&
                      h->tilt_rad >= limits.axis[1].min_position - 1e-9 &&
                      h->tilt_rad <= limits.axis[1].max_position + 1e-9 &&
                      h->zoom >= limits.axis[2].min_position - 1e-9 &&
                      h->zoom <= limits.axis[2].max_position + 1e-9;
      if (!ok) ++bad_states;
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
    int64_t n = countedIn(process, channel);
    for (const auto& c : it->second.counters) {
      const std::string prefix = channel + ".dropped_";
      if (c.name.rfind(prefix, 0) == 0 && c.name != prefix + "seq_gap") n += c.value;
    }
    return n;
  }
  // The messages a process took in on a channel.
  int64_t countedIn(const std::string& process, const std::string& channel) const {
    int64_t n = 0;
    for (const auto& c : status.at(process).channels) {
      if (c.channel == channel && c.direction == ptzstereo::channel_status_t::DIRECTION_IN) {
        n += c.messages;
      }
    }
    return n;
  }
  int64_t counter(const std::string& process, const std::string& name) const {
    for (const auto& c : status.at(process).counters) {
      if (c.name == name) return c.value;
    }
    return 0;
  }
};

// The longest silence between two arrivals from `from` on, us.
int64_t longestGapUs(const std::vector<int64_t>& arrivals_utime, size_t from, size_t to) {
  int64_t longest = 0;
  for (size_t i = from + 1; i < to; ++i) {
    longest = std::max(longest, arrivals_utime[i] - arrivals_utime[i - 1]);
  }
  return longest;
}

// Hostile messages: a third random bytes, a third truncated real encodings, a third well-formed
// with hostile values (non-finite numbers, extreme times and counts, wrong formats).
class Hostile {
 public:
  explicit Hostile(uint32_t seed) : rng_(seed) {}

  std::vector<uint8_t> make(const std::string& channel) {
    const int kind = static_cast<int>(rng_() % 3);
    select_reason_ = "undecodable";
    if (kind == 0) {
      std::vector<uint8_t> b(1 + rng_() % 3000);
      for (auto& x : b) x = static_cast<uint8_t>(rng_());
      return b;
    }
    std::vector<uint8_t> b = wellFormed(channel);
    if (kind == 1) {
      b.resize(rng_() % b.size());
      select_reason_ = "undecodable";
    }
    return b;
  }
  // For the last TARGET_SELECT made: why ptz-detect must drop it (one of kSelectReasons).
  const std::string& selectReason() const { return select_reason_; }

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
  // A request time: mostly now (so that most requests are judged on what they ask), else
  // hostile. *judged: how ptz-detect's freshness rule (2 s old at most, 0.1 s ahead) judges it;
  // the hostile times are an hour or more off.
  int64_t requestTime(std::string* judged) {
    const int64_t now = ptz::wallUtime();
    const int64_t t = rng_() % 4 ? now : hostileTime();
    *judged = t > now + 1'000'000 ? "future" : t < now - 1'000'000 ? "stale" : "fresh";
    return t;
  }
  // A name no detector class has: mostly short, one in eight 64 to 100 kB long (more than one
  // datagram).
  std::string hostileName() {
    if (rng_() % 8 == 0) return std::string(64'000 + rng_() % 36'000, 'x');
    return rng_() % 2 ? std::string(1 + rng_() % 200, 'x') : std::string("no_such_class");
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
    if (channel == "OBJECT_TRACKS") {
      ptzstereo::object_tracks_t m{};
      m.utime = hostileTime();
      m.publish_utime = hostileTime();
      m.frame_seq = static_cast<int64_t>(rng_());
      m.left_ptz = {hostileNumber(), 0, 1};
      m.right_ptz = {0, hostileNumber(), hostileNumber()};
      m.tracks.resize(rng_() % 4);
      for (auto& t : m.tracks) {
        t.id = static_cast<int64_t>(rng_() % 4);
        t.class_name = rng_() % 2 ? "red_ball" : hostileName();
        t.state = static_cast<int8_t>(static_cast<int>(rng_() % 5) - 1);  // -1, 3: no state
        for (double& v : t.position_m) v = hostileNumber();
        for (double& v : t.position_covariance_m2) v = hostileNumber();
        for (double& v : t.velocity_m_s) v = hostileNumber();
        for (double& v : t.velocity_covariance_m2_s2) v = hostileNumber();
        for (double& v : t.acceleration_m_s2) v = hostileNumber();
        t.radius_m = hostileNumber();
        t.age_s = hostileNumber();
        t.since_update_s = hostileNumber();
        t.object_index = static_cast<int32_t>(rng_());
        t.untrusted_updates = static_cast<int32_t>(rng_());
        t.has_orientation = rng_() % 2 == 1;
        for (double& v : t.orientation_wxyz) v = hostileNumber();
        for (double& v : t.orientation_covariance_rad2) v = hostileNumber();
      }
      m.num_tracks = static_cast<int32_t>(m.tracks.size());
      m.target_id = static_cast<int64_t>(rng_() % 6) - 1;
      m.target_reason = hostileName();
      return bytes(m);
    }
    if (channel == "TARGET_SELECT") return bytes(hostileSelect());
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

  // A well-formed request that cannot be met: an unknown class or track id, a point outside the
  // image or not finite, a camera or mode that does not exist.
  ptzstereo::target_select_t hostileSelect() {
    using T = ptzstereo::target_select_t;
    T m{};
    std::string publish_judged, capture_judged;
    m.publish_utime = requestTime(&publish_judged);
    m.utime = requestTime(&capture_judged);
    // The publish time is judged first.
    select_reason_ = publish_judged != "fresh"   ? publish_judged
                     : capture_judged != "fresh" ? capture_judged
                                                 : "refused";
    m.class_name = hostileName();
    m.frame_seq = static_cast<int64_t>(rng_());
    m.camera = static_cast<int8_t>(rng_() % 2);
    m.x_px = 320;
    m.y_px = 240;
    const double outside[] = {std::nan(""), INFINITY, -INFINITY, -1.0, 639.5, 1e300};
    const int64_t no_track[] = {0, -1, std::numeric_limits<int64_t>::min(),
                                std::numeric_limits<int64_t>::max(), 1'000'000'000'000};
    const int8_t no_camera[] = {2, -1, 127, -128};
    const int8_t no_mode[] = {3, 4, 127, -1, -128};
    switch (rng_() % 5) {
      case 0:  // tracks are numbered from 1 and never reach 10^12
        m.mode = T::MODE_TRACK_ID;
        m.track_id = no_track[rng_() % 5];
        break;
      case 1:
        m.mode = T::MODE_CLASS;
        break;
      case 2:  // x outside (or not a number), y anything
        m.mode = T::MODE_IMAGE_POINT;
        m.x_px = outside[rng_() % 6];
        m.y_px = hostileNumber();
        if (rng_() % 2) std::swap(m.x_px, m.y_px);
        break;
      case 3:  // a point in the image of a camera that does not exist
        m.mode = T::MODE_IMAGE_POINT;
        m.camera = no_camera[rng_() % 4];
        break;
      default:
        m.mode = no_mode[rng_() % 5];
        m.track_id = 1;  // a mode that is not track id does not look at it
        break;
    }
    return m;
  }

  std::mt19937 rng_;
  std::string select_reason_ = "undecodable";
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
  const size_t detect_start = l.tracks_arrivals_utime.size();
  const auto end = std::chrono::steady_clock::now() + 20s;
  auto next = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() < end) {
    for (const auto& ch : kChannels) {
      const std::vector<uint8_t> b = hostile.make(ch);
      const uint64_t hash = ptz::test::fnv1a(b);
      l.ours[ch].insert(hash);
      if (ch == "TARGET_SELECT") l.select_reason[hash] = hostile.selectReason();
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
  const size_t detect_end = l.tracks_arrivals_utime.size();
  // The loop's output: the longest silence between two of ptz-control's setpoints, and between
  // two of ptz-detect's answers to frames.
  const int64_t longest_stall_us = longestGapUs(l.setpoint_arrivals_utime, loop_start, loop_end);
  const int64_t longest_detect_stall_us =
      longestGapUs(l.tracks_arrivals_utime, detect_start, detect_end);
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
  const auto frozen_selects = l.selects_on_wire;
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
  // Every hostile target request dropped for the reason it was made to be, none followed.
  EXPECT_EQ(frozen_selects.count("not ours"), 0u);
  for (const auto& reason : kSelectReasons) {
    const int64_t want = frozen_selects.count(reason) ? frozen_selects.at(reason) : 0;
    const int64_t got = l.counter("ptz-detect", "TARGET_SELECT.dropped_" + reason);
    std::printf("ptz-detect  TARGET_SELECT dropped %-11s %5lld of %5lld\n", reason.c_str(),
                static_cast<long long>(got), static_cast<long long>(want));
    EXPECT_EQ(got, want) << reason;
  }
  EXPECT_EQ(l.countedIn("ptz-detect", "TARGET_SELECT"), 0);
  EXPECT_GT(frozen_selects.count("refused") ? frozen_selects.at("refused") : 0, 100)
      << "too few requests got past the freshness rule to be judged on what they ask";
  std::printf("setpoints from ptz-control during the attack: %zu, longest gap %.0f ms\n",
              loop_end - loop_start, longest_stall_us / 1000.0);
  std::printf("OBJECT_TRACKS from ptz-detect during the attack: %zu, longest gap %.0f ms\n",
              detect_end - detect_start, longest_detect_stall_us / 1000.0);
  EXPECT_GT(loop_end - loop_start, 200u);
  EXPECT_LT(longest_stall_us, 500'000);
  EXPECT_GT(detect_end - detect_start, 200u);
  EXPECT_LT(longest_detect_stall_us, 500'000);
  EXPECT_GT(l.states, 1000);
  EXPECT_EQ(l.bad_states, 0);
}
