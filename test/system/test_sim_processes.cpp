// ptz-sim as a separate process over real LCM (run inside a private network namespace).
#include <glob.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include "common/plant.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/child_process.hpp"
#include "support/data_dir.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

struct FrameCount {
  int64_t published = -1;  // the simulator's own count (its last status)
  int64_t skipped_late = 0;
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    for (const auto& c : m->counters) {
      if (c.name == "frames_published") published = c.value;
      if (c.name == "frames_skipped_late") skipped_late = c.value;
    }
  }
  int frames = 0;
  int decoded = 0;
  int64_t last_seq = -1;
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    ++frames;
    cv::Mat l, r;
    std::string err;
    if (ptz::decodeImage(m->left, &l, &err) && ptz::decodeImage(m->right, &r, &err) &&
        l.cols == 640 && r.rows == 480) {
      ++decoded;
    }
    last_seq = m->seq;
  }
};

void deliveryTest(const std::string& encoding) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  ASSERT_TRUE(lcm.good());
  FrameCount count;
  lcm.subscribe("STEREO_FRAME", &FrameCount::onFrame, &count);
  lcm.subscribe("PROCESS_STATUS_PTZ_SIM", &FrameCount::onStatus, &count);
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--frames", "300", "--encoding",
                    encoding, "--clock", "realtime"});
  ASSERT_TRUE(sim.started());
  // 10 s of frames: handle until the simulator exits, then until the wire is quiet.
  ptz::test::handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0; }, 30s);
  ptz::test::drain(lcm, 500ms);
  EXPECT_EQ(sim.wait(0ms), 0);
  // Delivery: >= 99 % of what the simulator published. (A frame it skipped because it ran
  // late on a loaded machine was never sent: that is the simulator's count, reported apart.)
  ASSERT_GT(count.published, 0) << "no status from ptz-sim";
  std::printf("%s: %d of %lld published frames received; %lld skipped late by the simulator\n",
              encoding.c_str(), count.frames, static_cast<long long>(count.published),
              static_cast<long long>(count.skipped_late));
  EXPECT_GE(count.frames, 0.99 * count.published) << encoding;
  // Every frame is accounted for: published, or skipped because the simulator ran late on a
  // loaded machine (its speed is the benchmark's business, not this test's).
  EXPECT_EQ(count.published + count.skipped_late, 300);
  EXPECT_GE(count.published, 150);
  EXPECT_EQ(count.decoded, count.frames);
  EXPECT_EQ(count.last_seq, count.published - 1);
}

// Answers every frame with a setpoint naming it; records what it saw.
struct LockstepClient {
  lcm::LCM* lcm;
  std::function<ptzstereo::ptz_setpoint_t(int64_t seq)> answer;
  std::vector<uint64_t> frame_hashes;
  std::vector<double> left_pan_at_capture;
  std::vector<int64_t> utimes;
  std::vector<ptzstereo::ptz_state_t> states;
  std::map<std::string, int64_t> counters;

  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    frame_hashes.push_back(ptz::test::fnv1a(m->right.data, ptz::test::fnv1a(m->left.data)));
    left_pan_at_capture.push_back(m->left.pan_rad);
    utimes.push_back(m->utime);
    ptzstereo::ptz_setpoint_t sp = answer(m->seq);
    sp.utime = m->utime;
    sp.frame_seq = m->seq;
    sp.publish_utime = ptz::wallUtime();
    lcm->publish("PTZ_SETPOINT", &sp);
  }
  void onState(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::ptz_state_t* m) {
    states.push_back(*m);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    for (const auto& c : m->counters) counters[c.name] = c.value;
  }
};

ptzstereo::ptz_setpoint_t holdPan(double pan) {
  ptzstereo::ptz_setpoint_t sp{};
  sp.left.pan_rad = pan;
  sp.left.zoom = 1;
  sp.right.pan_rad = pan;
  sp.right.zoom = 1;
  return sp;
}

std::unique_ptr<LockstepClient> runLockstep(
    const std::function<ptzstereo::ptz_setpoint_t(int64_t)>& answer, int frames,
    const std::vector<std::string>& extra = {}) {
  auto lcm = std::make_unique<lcm::LCM>(ptz::test::kTestUrl);
  auto client = std::make_unique<LockstepClient>();
  client->lcm = lcm.get();
  client->answer = answer;
  lcm->subscribe("STEREO_FRAME", &LockstepClient::onFrame, client.get());
  lcm->subscribe("PTZ_STATE", &LockstepClient::onState, client.get());
  lcm->subscribe("PROCESS_STATUS_PTZ_SIM", &LockstepClient::onStatus, client.get());
  std::vector<std::string> args = {PTZ_SIM_BIN,
                                   "--lcm-url",
                                   ptz::test::kTestUrl,
                                   "--frames",
                                   std::to_string(frames),
                                   "--clock",
                                   "lockstep",
                                   "--config",
                                   PTZ_SOURCE_DIR "/config/sim_default.yaml",
                                   "--lockstep-timeout-ms",
                                   "5000"};
  args.insert(args.end(), extra.begin(), extra.end());
  ChildProcess sim(args);
  EXPECT_TRUE(sim.started());
  ptz::test::handleUntil(
      *lcm, [&] { return sim.wait(0ms) >= 0; }, 60s);
  ptz::test::drain(*lcm, 300ms);
  EXPECT_EQ(sim.wait(0ms), 0);
  return client;
}

}  // namespace

TEST(SimProcess, DeliversRawVgaStereoAt30Hz) {
  deliveryTest("raw");
}

TEST(SimProcess, DeliversJpegVgaStereoAt30Hz) {
  deliveryTest("jpeg");
}

TEST(SimProcess, LockstepRunsAreByteIdentical) {
  auto answer = [](int64_t seq) { return holdPan(0.02 * std::sin(0.3 * seq)); };
  auto a = runLockstep(answer, 40, {"--encoding", "jpeg"});
  auto b = runLockstep(answer, 40, {"--encoding", "jpeg"});
  ASSERT_EQ(a->frame_hashes.size(), 40u);
  EXPECT_EQ(a->frame_hashes, b->frame_hashes);
  EXPECT_EQ(a->utimes, b->utimes);
  EXPECT_EQ(a->left_pan_at_capture, b->left_pan_at_capture);
  EXPECT_NE(a->frame_hashes.front(), a->frame_hashes.back());  // the cameras did move
  EXPECT_EQ(a->counters["lockstep_timeouts"], 0);
}

TEST(SimProcess, LockstepAppliesTheDeadTimeInSimTime) {
  const double tau = 0.1, T = 0.24, step = 0.2, fps = 30;
  auto run = runLockstep([&](int64_t) { return holdPan(step); }, 31,
                         {"--dead-time-s", "0.1", "--pan-max-rate", "100"});
  ASSERT_EQ(run->left_pan_at_capture.size(), 31u);
  // The answer to frame 0 is issued at t = 0 and moves the axis from t = tau on.
  for (size_t n = 0; n < run->left_pan_at_capture.size(); ++n) {
    const double t = n / fps;
    const double expected = t <= tau ? 0.0 : step * (1 - std::exp(-(t - tau) / T));
    EXPECT_NEAR(run->left_pan_at_capture[n], expected, 1e-9) << "frame " << n;
  }
  // Sim time in utime: frames exactly 1/30 s apart.
  for (size_t n = 1; n < run->utimes.size(); ++n) {
    EXPECT_NEAR(run->utimes[n] - run->utimes[n - 1], 1e6 / fps, 1.0);
  }
  EXPECT_GE(run->states.size(), 100u);  // 100 Hz states over 1 s of sim time
}

TEST(SimProcess, NoSetpointMovesAnAxisBeyondItsLimits) {
  const auto limits = ptz::defaultPlantParams();
  const double nan = std::nan("");
  auto answer = [&](int64_t seq) {
    ptzstereo::ptz_setpoint_t sp{};
    switch (seq % 4) {
      case 0:
        sp = holdPan(100.0);
        sp.left.tilt_rad = -50;
        sp.right.zoom = 1e9;
        break;
      case 1:
        sp = holdPan(nan);
        sp.left.zoom = INFINITY;
        break;
      case 2:
        sp = holdPan(-100.0);
        sp.right.tilt_rad = 50;
        break;
      default:
        sp = holdPan(0.5);
        break;
    }
    return sp;
  };
  auto run = runLockstep(answer, 60);
  ASSERT_GT(run->states.size(), 150u);
  for (const auto& s : run->states) {
    for (const auto* h : {&s.left, &s.right}) {
      ASSERT_GE(h->pan_rad, limits.axis[0].min_position);
      ASSERT_LE(h->pan_rad, limits.axis[0].max_position);
      ASSERT_GE(h->tilt_rad, limits.axis[1].min_position);
      ASSERT_LE(h->tilt_rad, limits.axis[1].max_position);
      ASSERT_GE(h->zoom, limits.axis[2].min_position);
      ASSERT_LE(h->zoom, limits.axis[2].max_position);
      ASSERT_TRUE(std::isfinite(h->pan_rad) && std::isfinite(h->zoom));
    }
  }
  // 15 setpoints of each kind: 4 clamped values per "case 0", 3 per "case 2"; 3 rejected per
  // "case 1" (both pans and the left zoom). The final status carries the totals.
  EXPECT_EQ(run->counters["setpoint_values_clamped"], 15 * 4 + 15 * 3);
  EXPECT_EQ(run->counters["setpoint_values_rejected"], 15 * 3);
  EXPECT_EQ(run->counters["setpoints_applied"], 60);
}

// The wall clock steps an hour ahead (NTP on a host that was off) while ptz-sim runs in real time,
// under libfaketime (its steady clock untouched): frames and states stay stamped on the wall
// clock every other process judges freshness by, captured just before they are published,
// instead of an hour behind it (their start time plus the steady clock's count).
TEST(SimProcess, StampsFollowAStepOfTheWallClock) {
  glob_t found{};  // Debian's libfaketime, in the machine's multiarch folder
  const bool have =
      glob("/usr/lib/*/faketime/libfaketime.so.1", 0, nullptr, &found) == 0 && found.gl_pathc > 0;
  const std::string lib = have ? found.gl_pathv[0] : "";
  globfree(&found);
  if (!have) {
    if (ptz::test::skipAllowed())
      GTEST_SKIP() << "libfaketime.so.1 absent: apt install libfaketime (scripts/install-deps)";
    FAIL() << "libfaketime.so.1 absent in CI (scripts/install-deps installs libfaketime)";
  }
  char dir[] = "/tmp/ptz_faketime_XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string offset_file = std::string(dir) + "/offset";
  const auto setOffset = [&](const std::string& offset) {
    std::ofstream(offset_file) << offset << "\n";
  };
  setOffset("+0");
  struct Stamps {
    std::vector<std::pair<int64_t, int64_t>> frames, states;  // utime, publish_utime
    void onFrame(const lcm::ReceiveBuffer*, const std::string&,
                 const ptzstereo::stereo_frame_t* m) {
      frames.emplace_back(m->utime, m->publish_utime);
    }
    void onState(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::ptz_state_t* m) {
      states.emplace_back(m->utime, m->publish_utime);
    }
  } stamps;
  lcm::LCM lcm(ptz::test::kTestUrl);
  ASSERT_TRUE(lcm.good());
  lcm.subscribe("STEREO_FRAME", &Stamps::onFrame, &stamps);
  lcm.subscribe("PTZ_STATE", &Stamps::onState, &stamps);
  ChildProcess sim({"/usr/bin/env", "LD_PRELOAD=" + lib, "FAKETIME_TIMESTAMP_FILE=" + offset_file,
                    "FAKETIME_NO_CACHE=1", "FAKETIME_DONT_FAKE_MONOTONIC=1", PTZ_SIM_BIN,
                    "--lcm-url", ptz::test::kTestUrl, "--frames", "120", "--encoding", "jpeg",
                    "--clock", "realtime"});
  ASSERT_TRUE(sim.started());
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return stamps.frames.size() >= 30; }, 20s));
  const size_t before = stamps.frames.size(), states_before = stamps.states.size();
  setOffset("+3600");
  ptz::test::handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0; }, 30s);
  ptz::test::drain(lcm, 300ms);
  std::filesystem::remove_all(dir);
  EXPECT_EQ(sim.wait(0ms), 0);
  ASSERT_GE(stamps.frames.size(), before + 30) << "too few frames after the step";
  // Each frame's capture a render's time before its publish (both on the process's wall clock):
  // under a second, an hour on either side of the step; but for one frame and one state at
  // most, stamped before the step and published after it (as on a real clock).
  const auto straddling = [](const std::vector<std::pair<int64_t, int64_t>>& v) {
    int n = 0;
    for (const auto& [utime, publish_utime] : v) {
      n += std::abs(publish_utime - utime) >= 1'000'000;
    }
    return n;
  };
  for (const auto& [utime, publish_utime] : stamps.frames) EXPECT_GE(publish_utime, utime);
  EXPECT_LE(straddling(stamps.frames), 1);
  EXPECT_LE(straddling(stamps.states), 1);
  EXPECT_GT(stamps.states.size(), states_before + 100);
  // And the step shows in the stamps: an hour and the frames' few seconds from first to last.
  const int64_t span_us = stamps.frames.back().first - stamps.frames.front().first;
  EXPECT_GT(span_us, 3600'000'000LL);
  EXPECT_LT(span_us, 3600'000'000LL + 30'000'000LL);
}
