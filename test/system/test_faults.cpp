// Faults a user's network and bad luck bring, against the real processes (private network
// namespace): messages that would crash a process or make it allocate, setpoints whose times
// overflow, a paused process's backlog, lost and undecodable messages counted exactly, starving
// inputs and a lost multicast route reported.
#include <gtest/gtest.h>
#include <signal.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <random>

#include "common/transport/message_check.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/rendered_frame.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;
using ptz::test::kTestUrl;

namespace {

struct Watch {
  std::map<int64_t, ptzstereo::object_pose_t> poses;                        // by frame seq
  std::vector<std::pair<int64_t, ptzstereo::object_pose_t>> pose_arrivals;  // (wall utime, pose)
  std::vector<std::pair<int64_t, ptzstereo::ptz_setpoint_t>> setpoints;
  ptzstereo::ptz_state_t state{};
  int64_t states = 0;
  std::map<std::string, ptzstereo::process_status_t> status;  // the last, by process

  // Checked like the processes' own intake: the hostile poses these tests send would otherwise
  // make the test itself allocate what they ask for (seconds and gigabytes of its own).
  void onPose(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    ptzstereo::object_pose_t m;
    std::string why;
    if (!ptz::decodeChecked(rbuf->data, rbuf->data_size, &m, &why)) return;
    poses[m.frame_seq] = m;
    pose_arrivals.emplace_back(ptz::wallUtime(), m);
  }
  void onSetpoint(const lcm::ReceiveBuffer*, const std::string&,
                  const ptzstereo::ptz_setpoint_t* m) {
    setpoints.emplace_back(ptz::wallUtime(), *m);
  }
  void onState(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::ptz_state_t* m) {
    state = *m;
    ++states;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    status[m->process] = *m;
  }
  bool up(const std::string& process) const { return status.count(process) > 0; }
  int64_t counter(const std::string& process, const std::string& name) const {
    auto it = status.find(process);
    if (it == status.end()) return 0;
    for (const auto& c : it->second.counters) {
      if (c.name == name) return c.value;
    }
    return 0;
  }
};

class Faults : public ::testing::Test {
 protected:
  Faults() {
    lcm.subscribe("OBJECT_POSE", &Watch::onPose, &w);
    lcm.subscribe("PTZ_SETPOINT", &Watch::onSetpoint, &w);
    lcm.subscribe("PTZ_STATE", &Watch::onState, &w);
    lcm.subscribe("PROCESS_STATUS_.*", &Watch::onStatus, &w);
  }
  // Waits until every one of processes has published its first status.
  ::testing::AssertionResult up(const std::vector<std::string>& processes) {
    if (ptz::test::handleUntil(
            lcm,
            [&] {
              return std::all_of(processes.begin(), processes.end(),
                                 [&](const std::string& p) { return w.up(p); });
            },
            20s)) {
      return ::testing::AssertionSuccess();
    }
    return ::testing::AssertionFailure() << "not all of the processes came up";
  }

  lcm::LCM lcm{kTestUrl};
  Watch w;
};

// Peak resident memory of a process, kB (VmHWM).
int64_t peakRssKb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  int64_t value = -1;
  while (in >> key) {
    if (key == "VmHWM:") {
      in >> value;
      break;
    }
  }
  return value;
}

template <class Msg>
std::vector<uint8_t> bytesOf(const Msg& m) {
  std::vector<uint8_t> b(static_cast<size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

void putInt32(std::vector<uint8_t>* b, size_t at, int32_t v) {
  for (int i = 0; i < 4; ++i) {
    (*b)[at + i] = static_cast<uint8_t>(static_cast<uint32_t>(v) >> (24 - 8 * i));
  }
}

std::vector<std::string> detectArgs() {
  return {PTZ_DETECT_BIN,
          "--lcm-url",
          kTestUrl,
          "--config",
          PTZ_SOURCE_DIR "/config/detect_default.yaml",
          "--status-period-s",
          "0.05"};
}

// Publishes a good frame (stamped now) and waits for ptz-detect's pose answering it.
::testing::AssertionResult answered(lcm::LCM& lcm, Watch& w, int64_t seq,
                                    std::chrono::milliseconds within) {
  ptz::test::publishNow(lcm, "STEREO_FRAME", ptz::test::ballFrame(seq));
  if (ptz::test::handleUntil(
          lcm, [&] { return w.poses.count(seq) > 0; }, within)) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure()
         << "no pose for frame " << seq << " within " << within.count() << " ms";
}

}  // namespace

TEST_F(Faults, DetectSurvivesAFrameWhoseRightImageIsGray) {
  ChildProcess detect(detectArgs());
  ASSERT_TRUE(up({"ptz-detect"}));
  ptzstereo::stereo_frame_t frame = ptz::test::ballFrame(1);
  cv::Mat gray(480, 640, CV_8UC1, cv::Scalar(90));
  frame.right = ptz::encodeImage(gray, ptzstereo::image_t::ENCODING_RAW, 90);
  ptz::test::publishNow(lcm, "STEREO_FRAME", frame);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.counter("ptz-detect", "STEREO_FRAME.dropped_size_mismatch") == 1; },
      10s));
  EXPECT_TRUE(detect.running()) << "ptz-detect died of a gray right image";
  EXPECT_TRUE(answered(lcm, w, 2, 5s));
  EXPECT_EQ(w.poses.count(1), 0u);
}

TEST_F(Faults, ASmallMessageCannotMakeDetectAllocateOrStall) {
  ChildProcess detect(detectArgs());
  ASSERT_TRUE(up({"ptz-detect"}));
  ASSERT_TRUE(answered(lcm, w, 1, 10s));
  const int64_t rss_before_kb = peakRssKb(detect.pid());
  ASSERT_GT(rss_before_kb, 0) << "no /proc entry for ptz-detect (run_in_netns.sh mounts /proc)";

  // data_size = 2^31 - 1 in a 100-byte message.
  ptzstereo::stereo_frame_t tiny{};
  tiny.left.width = tiny.right.width = 640;
  tiny.left.height = tiny.right.height = 480;
  std::vector<uint8_t> b = bytesOf(tiny);
  putInt32(&b, 8 + 24 + 38, 2147483647);
  lcm.publish("STEREO_FRAME", b.data(), static_cast<unsigned>(b.size()));
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.counter("ptz-detect", "dropped_undecodable") == 1; }, 10s));
  EXPECT_TRUE(answered(lcm, w, 2, 2s));

  // 650-byte JPEGs whose headers say 30000 x 30000 in a message that says 640 x 480.
  ptzstereo::stereo_frame_t big = ptz::test::ballFrame(3);
  big.left = ptz::encodeImage(cv::Mat(480, 640, CV_8UC3, cv::Scalar(0, 0, 200)),
                              ptzstereo::image_t::ENCODING_JPEG, 10);
  for (size_t i = 2; i + 9 < big.left.data.size(); ++i) {
    if (big.left.data[i] == 0xFF && big.left.data[i + 1] == 0xC0) {
      for (size_t k : {5, 7}) {
        big.left.data[i + k] = 30000 >> 8;
        big.left.data[i + k + 1] = 30000 & 0xFF;
      }
      break;
    }
  }
  big.right = big.left;
  ptz::test::publishNow(lcm, "STEREO_FRAME", big);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.counter("ptz-detect", "dropped_bad_image") == 1; }, 10s));
  EXPECT_TRUE(answered(lcm, w, 4, 2s));
  const int64_t rss_after_kb = peakRssKb(detect.pid());
  std::printf("ptz-detect peak RSS %lld kB before, %lld kB after the hostile frames\n",
              static_cast<long long>(rss_before_kb), static_cast<long long>(rss_after_kb));
  EXPECT_LT(rss_after_kb - rss_before_kb, 64 * 1024);
}

// ptz-depth reads OBJECT_POSE, ptz-control OBJECT_TRACKS: each gets its own message whose count
// (the last field of an empty message) says ten million.
TEST_F(Faults, AMessageOfTenMillionObjectsCostsControlAndDepthNothing) {
  ChildProcess control({PTZ_CONTROL_BIN, "--lcm-url", kTestUrl, "--status-period-s", "0.05"});
  ChildProcess depth({PTZ_DEPTH_BIN, "--lcm-url", kTestUrl, "--status-period-s", "0.05"});
  ASSERT_TRUE(up({"ptz-control", "ptz-depth"}));
  const int64_t control_before_kb = peakRssKb(control.pid());
  const int64_t depth_before_kb = peakRssKb(depth.pid());
  ASSERT_GT(control_before_kb, 0);
  ASSERT_GT(depth_before_kb, 0);
  std::vector<uint8_t> pose = bytesOf(ptzstereo::object_pose_t{});
  putInt32(&pose, pose.size() - 4, 10'000'000);
  std::vector<uint8_t> tracks = bytesOf(ptzstereo::object_tracks_t{});
  putInt32(&tracks, tracks.size() - 4, 10'000'000);
  // One at a time, each counted by both before the next.
  for (int i = 1; i <= 5; ++i) {
    lcm.publish("OBJECT_POSE", pose.data(), static_cast<unsigned>(pose.size()));
    lcm.publish("OBJECT_TRACKS", tracks.data(), static_cast<unsigned>(tracks.size()));
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm,
        [&] {
          return w.counter("ptz-control", "OBJECT_TRACKS.dropped_undecodable") == i &&
                 w.counter("ptz-depth", "OBJECT_POSE.dropped_undecodable") == i;
        },
        20s))
        << "message " << i << ": ptz-control counted "
        << w.counter("ptz-control", "OBJECT_TRACKS.dropped_undecodable") << ", ptz-depth "
        << w.counter("ptz-depth", "OBJECT_POSE.dropped_undecodable");
  }
  EXPECT_LT(peakRssKb(control.pid()) - control_before_kb, 16 * 1024);
  EXPECT_LT(peakRssKb(depth.pid()) - depth_before_kb, 16 * 1024);
  EXPECT_TRUE(control.running());
  EXPECT_TRUE(depth.running());
}

TEST_F(Faults, TheSimulatorRefusesSetpointsWithOverflowingOrFutureTimes) {
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", kTestUrl, "--clock", "realtime", "--frame-rate-hz",
                    "5", "--encoding", "jpeg", "--status-period-s", "0.05"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.states > 0 && w.up("ptz-sim"); }, 20s));
  auto setpoint = [](int64_t utime, int64_t publish_utime) {
    ptzstereo::ptz_setpoint_t s{};
    s.utime = utime;
    s.publish_utime = publish_utime;
    s.frame_seq = -1;
    s.left = {1.0, 0.0, 1.0};
    s.right = {1.0, 0.0, 1.0};
    return s;
  };
  constexpr int64_t kMin = std::numeric_limits<int64_t>::min();
  constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
  const int64_t now = ptz::wallUtime();
  const std::vector<std::pair<ptzstereo::ptz_setpoint_t, std::string>> hostile = {
      {setpoint(now, kMin), "dropped_setpoint_stale"},
      {setpoint(kMin, now), "dropped_setpoint_stale"},
      {setpoint(now, now + 10'000'000), "dropped_setpoint_future"},
      {setpoint(kMax, now), "dropped_setpoint_future"},
      {setpoint(now, kMax), "dropped_setpoint_future"},
      {setpoint(now - 3'000'000, now), "dropped_setpoint_stale"},  // answers a 3 s old frame
  };
  std::map<std::string, int64_t> expected;
  for (const auto& [msg, counter] : hostile) {
    lcm.publish("PTZ_SETPOINT", &msg);
    const int64_t want = ++expected[counter];
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm, [&, c = counter] { return w.counter("ptz-sim", c) == want; }, 10s))
        << counter;
  }
  // Judged and refused: the heads never moved, and nothing was applied.
  const int64_t states_after = w.states;
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.states > states_after + 5; }, 5s));
  EXPECT_LT(std::abs(w.state.left.pan_rad), 1e-6);
  EXPECT_EQ(w.counter("ptz-sim", "setpoints_applied"), 0);
  // A fresh one is applied: the heads turn.
  const int64_t fresh = ptz::wallUtime();
  const auto good = setpoint(fresh, fresh);
  lcm.publish("PTZ_SETPOINT", &good);
  EXPECT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.state.left.pan_rad > 0.05; }, 5s));
}

TEST_F(Faults, AfterAPauseTheFirstAnswersAreToFreshFrames) {
  ChildProcess detect(detectArgs());
  ChildProcess control({PTZ_CONTROL_BIN, "--lcm-url", kTestUrl, "--status-period-s", "0.1"});
  ASSERT_TRUE(up({"ptz-detect", "ptz-control"}));
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", kTestUrl, "--clock", "realtime", "--encoding", "jpeg",
                    "--config", PTZ_SOURCE_DIR "/config/sim_default.yaml", "--status-period-s",
                    "0.1"});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.setpoints.size() > 30; }, 20s));
  for (ChildProcess* paused : {&detect, &control}) {
    kill(paused->pid(), SIGSTOP);
    ptz::test::handleUntil(
        lcm, [] { return false; }, 3s);  // 3 s of frames pile up
    const size_t setpoints_before = w.setpoints.size();
    const size_t poses_before = w.pose_arrivals.size();
    kill(paused->pid(), SIGCONT);
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm, [&] { return w.setpoints.size() > setpoints_before + 5; }, 10s));
    // The first answers after the pause are to frames captured just before them, not 3 s ago.
    if (paused == &detect) {
      ASSERT_GT(w.pose_arrivals.size(), poses_before);
      const auto& [arrived, pose] = w.pose_arrivals[poses_before];
      EXPECT_LT(arrived - pose.utime, 500'000)
          << "ptz-detect answered a frame " << (arrived - pose.utime) / 1000 << " ms old";
    }
    const auto& [arrived, sp] = w.setpoints[setpoints_before];
    EXPECT_LT(arrived - sp.utime, 500'000)
        << (paused == &detect ? "after ptz-detect's pause" : "after ptz-control's pause")
        << ": the first setpoint answered a frame " << (arrived - sp.utime) / 1000 << " ms old";
  }
  EXPECT_GT(w.counter("ptz-detect", "STEREO_FRAME.dropped_stale") +
                w.counter("ptz-detect", "STEREO_FRAME.dropped_superseded"),
            0);
  EXPECT_GT(w.counter("ptz-control", "OBJECT_TRACKS.dropped_stale") +
                w.counter("ptz-control", "OBJECT_TRACKS.dropped_superseded"),
            0);
}

TEST_F(Faults, EveryLostOrUndecodableFrameIsCountedExactly) {
  ChildProcess detect(detectArgs());
  ASSERT_TRUE(up({"ptz-detect"}));
  // 60 frames, of which seqs 20..24 and 40..44 never come: 10 lost on the way.
  int64_t sent = 0;
  for (int64_t seq = 0; seq < 60; ++seq) {
    if ((seq >= 20 && seq < 25) || (seq >= 40 && seq < 45)) continue;
    ASSERT_TRUE(answered(lcm, w, seq, 5s));
    ++sent;
  }
  std::mt19937 rng(7);
  for (int i = 0; i < 40; ++i) {
    std::vector<uint8_t> junk(1 + rng() % 2000);
    for (auto& byte : junk) byte = static_cast<uint8_t>(rng());
    lcm.publish("STEREO_FRAME", junk.data(), static_cast<unsigned>(junk.size()));
    ASSERT_TRUE(ptz::test::handleUntil(
        lcm, [&] { return w.counter("ptz-detect", "STEREO_FRAME.dropped_undecodable") == i + 1; },
        5s));
  }
  ASSERT_TRUE(answered(lcm, w, 60, 5s));
  ++sent;
  // The status after the last frame's pose.
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.counter("ptz-detect", "frames_processed") == sent; }, 5s));
  EXPECT_EQ(w.counter("ptz-detect", "STEREO_FRAME.dropped_seq_gap"), 10);
  const auto& channels = w.status["ptz-detect"].channels;
  const auto in = std::find_if(channels.begin(), channels.end(), [](const auto& c) {
    return c.channel == "STEREO_FRAME" && c.direction == ptzstereo::channel_status_t::DIRECTION_IN;
  });
  ASSERT_NE(in, channels.end());
  EXPECT_EQ(in->dropped, 50);
  EXPECT_EQ(in->messages, sent);
}

TEST_F(Faults, ProcessesSayWhenTheirInputStops) {
  ChildProcess detect(detectArgs());
  ChildProcess control({PTZ_CONTROL_BIN, "--lcm-url", kTestUrl, "--status-period-s", "0.1"});
  using S = ptzstereo::process_status_t;
  auto state = [&](const std::string& p) { return w.up(p) ? w.status[p].state : int8_t{-1}; };
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] { return state("ptz-detect") == S::STATE_WARN && state("ptz-control") == S::STATE_WARN; },
      20s));
  EXPECT_EQ(w.status["ptz-detect"].message.rfind("no STEREO_FRAME for ", 0), 0u)
      << w.status["ptz-detect"].message;
  EXPECT_EQ(w.status["ptz-control"].message.rfind("no OBJECT_TRACKS for ", 0), 0u)
      << w.status["ptz-control"].message;
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] {
        return state("ptz-detect") == S::STATE_ERROR && state("ptz-control") == S::STATE_ERROR;
      },
      20s));
  EXPECT_EQ(w.status["ptz-detect"].message, "no STEREO_FRAME for 5 s");
  // Input again: OK again (the frame's tracks message feeds ptz-control too).
  ASSERT_TRUE(answered(lcm, w, 1, 5s));
  EXPECT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] { return state("ptz-detect") == S::STATE_OK && state("ptz-control") == S::STATE_OK; },
      5s));
}

TEST_F(Faults, AProcessThatCannotPublishSaysSo) {
  const std::string err = std::string(::testing::TempDir()) + "/detect_stderr.txt";
  ChildProcess detect(detectArgs(), err);
  ASSERT_TRUE(up({"ptz-detect"}));
  ASSERT_EQ(std::system("ip route del 224.0.0.0/4 dev lo"), 0);
  auto stderrText = [&] {
    std::ifstream in(err);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (stderrText().find("cannot publish") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline) {
    lcm.handleTimeout(50);  // nothing can arrive: this is the wait
  }
  ASSERT_EQ(std::system("ip route add 224.0.0.0/4 dev lo"), 0);
  const std::string text = stderrText();
  EXPECT_NE(text.find("ptz-detect: cannot publish PROCESS_STATUS_PTZ_DETECT"), std::string::npos)
      << text;
  // Back on the network, it tells what happened while it was off.
  w.status.clear();
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.up("ptz-detect"); }, 10s));
  EXPECT_EQ(w.status["ptz-detect"].state, ptzstereo::process_status_t::STATE_ERROR);
  EXPECT_NE(w.status["ptz-detect"].message.find("cannot publish PROCESS_STATUS_PTZ_DETECT"),
            std::string::npos)
      << w.status["ptz-detect"].message;
  EXPECT_GT(w.counter("ptz-detect", "publish_failures"), 0);
  EXPECT_TRUE(detect.running());
}

// LCM 1.3.1 says a message it sends in fragments (a frame) went out even when no route took it:
// the status counts it as a failure all the same, and a small message too.
TEST_F(Faults, AFrameWithNoRouteIsCountedAsNotPublished) {
  ptz::Params params("ptz-test", "");
  ptz::addTransportParams(params);
  ptz::StatusReporter status(&lcm, params, "ptz-test");
  const cv::Mat image(240, 320, CV_8UC3, cv::Scalar(1, 2, 3));  // 230 kB raw: fragmented
  const ptzstereo::stereo_frame_t frame =
      ptz::makeStereoFrame(1, 1, image, {}, image, {}, ptzstereo::image_t::ENCODING_RAW, 90);
  ASSERT_GT(frame.getEncodedSize(), ptz::kLcmLargestDatagramBytes);
  ptzstereo::ptz_state_t small{};
  ASSERT_TRUE(status.publishOn(lcm, "STEREO_FRAME", frame));
  ASSERT_TRUE(status.publishOn(lcm, "PTZ_STATE", small));
  ASSERT_EQ(std::system("ip route del 224.0.0.0/4 dev lo"), 0);
  testing::internal::CaptureStderr();
  const bool frame_sent = status.publishOn(lcm, "STEREO_FRAME", frame);
  const bool state_sent = status.publishOn(lcm, "PTZ_STATE", small);
  testing::internal::GetCapturedStderr();
  ASSERT_EQ(std::system("ip route add 224.0.0.0/4 dev lo"), 0);
  EXPECT_FALSE(frame_sent);
  EXPECT_FALSE(state_sent);
  EXPECT_EQ(status.counter("STEREO_FRAME.publish_failures"), 1);
  EXPECT_EQ(status.counter("PTZ_STATE.publish_failures"), 1);
  EXPECT_EQ(status.health().first, ptzstereo::process_status_t::STATE_ERROR);
  // The route back: sent again, and nothing counted that was not.
  EXPECT_TRUE(status.publishOn(lcm, "STEREO_FRAME", frame));
  EXPECT_EQ(status.counter("STEREO_FRAME.publish_failures"), 1);
}
