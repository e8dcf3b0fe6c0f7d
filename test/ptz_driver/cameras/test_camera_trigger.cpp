// The hardware trigger line: the pulser's edges on a simulated chip in simulated time (rate, width,
// polarity, periods missed when the machine was busy), frames stamped with the pulse they answer
// (pairs exact where capture-time pairing fails), a camera that does not follow the trigger named
// in the status, and the parameters' checks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include "ptz_driver/cameras/sources/capture_source.hpp"
#include "ptz_driver/cameras/stereo_camera.hpp"
#include "ptz_driver/cameras/trigger.hpp"
#include "ptz_driver/emulators/emulated_gpio_chip.hpp"
#include "support/hardware/fake_frame_source.hpp"

using namespace ptz::driver;
using ptz::test::FakeCamera;

namespace {

constexpr int64_t kWallStart = 1'700'000'000'000'000;  // wall clock at simulated time 0
constexpr int kLine = 7;
constexpr int64_t kPeriodUs = 33'333;

// Simulated time: sleeping moves it to the deadline, late by `late_s` once when asked. Each
// reading of the wall clock may take wall_read_us (as if the edge's ioctl took that long).
struct SimClock {
  double now_s = 100.0;
  double late_once_s = 0;
  int64_t wall_read_us = 0, wall_reads = 0;
  PulseClock clock() {
    return {
        [this] { return now_s; },
        [this](double t_s) {
          now_s = std::max(now_s, t_s) + late_once_s;
          late_once_s = 0;
        },
        [this] { return kWallStart + std::llround(now_s * 1e6) + wall_read_us * wall_reads++; }};
  }
};

TriggerParams trigger(bool active_low = false) {
  TriggerParams t;
  t.chip = "sim";
  t.line = kLine;
  t.rate_hz = 30;
  t.pulse_s = 0.002;
  t.active_low = active_low;
  return t;
}

struct Pulsing {
  SimClock sim;
  EmulatedGpioChip chip{{}, 100.0, 1e-4};
  TriggerLog log;
  std::unique_ptr<TriggerPulser> pulser;
  explicit Pulsing(const TriggerParams& t) {
    chip.useClock([this] { return sim.now_s; });
    chip.addOutput(kLine);
    chip.requestOutput(kLine, "trigger_line", t.active_low);
    pulser = std::make_unique<TriggerPulser>(chip, t, log, sim.clock());
  }
};

int64_t pulseUtime(int k) {
  return kWallStart + 100'000'000 + std::llround(k * 1e6 / 30);
}

CameraConfig liveConfig() {
  CameraConfig c;
  c.source[0] = parseSource("0", "left_source");
  c.source[1] = parseSource("1", "right_source");
  c.pairer = {3'000, 30, 2.0};
  c.max_rate_hz = 0;
  c.trigger = trigger();
  return c;
}

}  // namespace

TEST(CameraTrigger, PulsesComeAtTheRateWithTheirWidthAndEachIsLogged) {
  Pulsing p(trigger());
  EXPECT_FALSE(p.chip.level(kLine));
  p.pulser->run(30);
  const EmulatedGpioChip::OutputTally tally = p.chip.tally(kLine);
  EXPECT_EQ(tally.rising, 30);
  EXPECT_NEAR(tally.high_s, 30 * 0.002, 2e-4);  // the chip's 0.1 ms steps
  EXPECT_FALSE(p.chip.level(kLine));
  EXPECT_EQ(p.log.pulses(), 30);
  EXPECT_EQ(p.pulser->missedPeriods(), 0);
  for (int k : {0, 1, 17, 29}) {
    const auto n = p.log.nearest(pulseUtime(k) + 5'000);
    ASSERT_TRUE(n);
    EXPECT_EQ(n->pulse_utime, pulseUtime(k));
    EXPECT_EQ(n->offset_us, 5'000);
  }
  // Nearest either way.
  EXPECT_EQ(p.log.nearest(pulseUtime(3) - 2'000)->pulse_utime, pulseUtime(3));
  EXPECT_EQ(p.log.nearest(pulseUtime(3) + 20'000)->pulse_utime, pulseUtime(4));
}

TEST(CameraTrigger, ActiveLowIdlesHighAndPulsesLow) {
  Pulsing p(trigger(true));
  EXPECT_TRUE(p.chip.level(kLine));  // inactive from the request on: no edge before the first
  EXPECT_EQ(p.chip.tally(kLine).rising, 0);
  p.pulser->run(10);
  const EmulatedGpioChip::OutputTally tally = p.chip.tally(kLine);
  // Low 2 ms of each 33.3 ms period; the last period ends 2 ms after its pulse.
  EXPECT_NEAR(tally.at_s - 100.0 - tally.high_s, 10 * 0.002, 2e-4);
  EXPECT_TRUE(p.chip.level(kLine));
  p.pulser->stop();
  EXPECT_TRUE(p.chip.level(kLine));
}

TEST(CameraTrigger, APeriodStartedTooLateIsSkippedAndCountedNotPulsedLate) {
  Pulsing p(trigger());
  p.pulser->run(10);
  p.sim.late_once_s = 0.6 / 30;  // the machine busy at period 10's start
  p.pulser->run(20);
  EXPECT_EQ(p.pulser->missedPeriods(), 1);
  EXPECT_EQ(p.log.pulses(), 29);
  EXPECT_EQ(p.chip.tally(kLine).rising, 29);
  // No pulse near period 10's time; the later ones back on the grid.
  EXPECT_GT(std::llabs(p.log.nearest(pulseUtime(10))->offset_us), 16'000);
  EXPECT_EQ(p.log.nearest(pulseUtime(11))->offset_us, 0);
  EXPECT_EQ(p.log.nearest(pulseUtime(29))->offset_us, 0);
  // Late by less than half a period: pulsed, logged when it really happened, full width.
  p.sim.late_once_s = 0.004;
  const double high_before_s = p.chip.tally(kLine).high_s;
  p.pulser->run(1);
  EXPECT_EQ(p.pulser->missedPeriods(), 1);
  EXPECT_EQ(p.log.nearest(pulseUtime(30))->offset_us, -4'000);
  // Every edge's lateness: 29 on time, then the one 4 ms late (the skipped period has none).
  const std::vector<double> late_s = p.pulser->takeEdgeLatenessS();
  ASSERT_EQ(late_s.size(), 30u);
  for (size_t k = 0; k < 29; ++k) EXPECT_NEAR(late_s[k], 0, 1e-9) << k;
  EXPECT_NEAR(late_s[29], 0.004, 1e-9);
  EXPECT_TRUE(p.pulser->takeEdgeLatenessS().empty());
  EXPECT_NEAR(p.chip.tally(kLine).high_s - high_before_s, 0.002, 2e-4);
}

TEST(CameraTrigger, APulseIsLoggedBetweenTheClockReadingsAroundItsEdge) {
  Pulsing p(trigger());
  p.sim.wall_read_us = 300;  // the readings before and after the edge 300 us apart
  p.pulser->run(3);
  // Pulse k: read at the k-th pair of readings, 2k x 300 us and (2k + 1) x 300 us late.
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(p.log.nearest(pulseUtime(k))->offset_us, -(2 * k * 300 + 150)) << k;
  }
}

TEST(CameraTrigger, FailedWritesAndMissedPeriodsShowInTheStatusForAWhile) {
  TriggerLineHealth health(14, 2.0);
  bool error = true;
  EXPECT_EQ(health.update(kWallStart, 0, 0, &error), "");
  EXPECT_FALSE(error);
  EXPECT_EQ(health.update(kWallStart + 100'000, 0, 3, &error),
            "trigger: 3 periods missed (the machine was busy: run under chrt -f)");
  EXPECT_FALSE(error);
  EXPECT_EQ(health.update(kWallStart + 200'000, 5, 3, &error),
            "trigger line 14: 5 writes failed; trigger: 3 periods missed (the machine was busy: "
            "run under chrt -f)");
  EXPECT_TRUE(error);
  // No new ones: the missed periods are forgotten 2 s after the last, then the failed writes.
  EXPECT_EQ(health.update(kWallStart + 2'150'000, 5, 3, &error),
            "trigger line 14: 5 writes failed");
  EXPECT_TRUE(error);
  EXPECT_EQ(health.update(kWallStart + 2'250'000, 5, 3, &error), "");
  EXPECT_FALSE(error);
}

TEST(CameraTrigger, FramesAreStampedWithTheirPulseAndPairExactly) {
  TriggerLog log;
  for (int k = 0; k < 40; ++k) log.add(pulseUtime(k));
  // The right camera's frames reach us 5.5 ms later than the left's, give or take 2 ms: beyond
  // the 3 ms pairing tolerance, but each within the window of the same pulse.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int64_t> left_late(0, 1'000), right_late(4'500, 7'500);
  auto feed = [&](FakeCamera& left, FakeCamera& right) {
    for (int k = 0; k < 30; ++k) {
      left.push(pulseUtime(k) + left_late(rng), k);
      right.push(pulseUtime(k) + right_late(rng), k);
    }
  };
  auto left = std::make_shared<FakeCamera>(), right = std::make_shared<FakeCamera>();
  StereoCamera camera(liveConfig(), {ptz::test::fakeFactory(left), ptz::test::fakeFactory(right)},
                      &log);
  // The heads turn at 1 rad/s (left) and -1 rad/s (right); PTZ_STATE at 50 Hz.
  auto pan = [](int64_t utime) { return static_cast<double>(utime - pulseUtime(0)) * 1e-6; };
  for (int64_t t = pulseUtime(0) - 20'000; t <= pulseUtime(31); t += 20'000) {
    ASSERT_TRUE(camera.onPtzState(t, {pan(t), 0, 1}, {-pan(t), 0, 1}));
  }
  feed(*left, *right);
  const auto pairs = camera.step(pulseUtime(30));
  ASSERT_EQ(pairs.size(), 30u);
  for (size_t k = 0; k < pairs.size(); ++k) {
    EXPECT_EQ(pairs[k].left.index, static_cast<int64_t>(k));
    EXPECT_EQ(pairs[k].right.index, static_cast<int64_t>(k));
    EXPECT_EQ(pairs[k].left.capture_utime, pulseUtime(static_cast<int>(k)));
    EXPECT_EQ(pairs[k].right.capture_utime, pulseUtime(static_cast<int>(k)));
    // Each image's pose at the pulse, not at its own arrival (0-7.5 ms later: up to 7.5 mrad).
    EXPECT_NEAR(pairs[k].left_pose.pan_rad, pan(pulseUtime(static_cast<int>(k))), 1e-9);
    EXPECT_NEAR(pairs[k].right_pose.pan_rad, -pan(pulseUtime(static_cast<int>(k))), 1e-9);
  }
  const auto c = camera.counters();
  EXPECT_EQ(c.at("trigger_matched_left"), 30);
  EXPECT_EQ(c.at("trigger_matched_right"), 30);
  EXPECT_EQ(c.at("trigger_unmatched_right"), 0);
  EXPECT_NEAR(c.at("trigger_offset_us_p50_left"), 500, 300);
  EXPECT_NEAR(c.at("trigger_offset_us_p50_right"), 6'000, 800);
  std::string message;
  EXPECT_EQ(camera.health(pulseUtime(30), &message), Health::kOk) << message;

  // The same frames without the trigger: paired by their own times, never within 3 ms.
  CameraConfig untriggered = liveConfig();
  untriggered.trigger = {};
  auto left2 = std::make_shared<FakeCamera>(), right2 = std::make_shared<FakeCamera>();
  StereoCamera plain(untriggered, {ptz::test::fakeFactory(left2), ptz::test::fakeFactory(right2)});
  feed(*left2, *right2);
  EXPECT_TRUE(plain.step(pulseUtime(30)).empty());
}

TEST(CameraTrigger, ACameraThatDoesNotFollowThePulsesIsNamed) {
  TriggerLog log;
  for (int k = 0; k < 80; ++k) log.add(pulseUtime(k));
  auto left = std::make_shared<FakeCamera>(), right = std::make_shared<FakeCamera>();
  StereoCamera camera(liveConfig(), {ptz::test::fakeFactory(left), ptz::test::fakeFactory(right)},
                      &log);
  // Left triggered; right free-running at 23 Hz (not in trigger mode).
  std::vector<StampedPair> pairs;
  int next_right = 0;
  int64_t now = 0;
  for (int k = 0; k < 60; ++k) {
    left->push(pulseUtime(k) + 1'000, k);
    now = pulseUtime(k) + 5'000;
    for (; next_right < 46; ++next_right) {
      const int64_t t = pulseUtime(0) + std::llround(next_right * 1e6 / 23);
      if (t > now) break;
      right->push(t, next_right);
    }
    for (auto& p : camera.step(now)) pairs.push_back(std::move(p));
  }
  ASSERT_EQ(next_right, 46);
  const auto c = camera.counters();
  EXPECT_EQ(c.at("trigger_matched_left"), 60);
  EXPECT_GT(c.at("trigger_unmatched_right"), 23);
  // Each right frame that happened to lie near a pulse paired with the left frame of that pulse.
  EXPECT_EQ(static_cast<int64_t>(pairs.size()), c.at("trigger_matched_right"));
  for (const auto& p : pairs) EXPECT_EQ(p.left.capture_utime, p.right.capture_utime);
  std::string message;
  EXPECT_EQ(camera.health(now, &message), Health::kError);
  EXPECT_EQ(message.find("left camera"), std::string::npos) << message;
  EXPECT_EQ(message.rfind("right camera: " + std::to_string(c.at("trigger_unmatched_right")) +
                              " of 46 frames in the last 2.0 s answered no trigger pulse (" +
                              std::to_string(c.at("trigger_unmatched_right")) +
                              " none within 8.3 ms, median distance ",
                          0),
            0u)
      << message;
  EXPECT_NE(message.find("is it in external-trigger mode"), std::string::npos) << message;
}

TEST(CameraTrigger, AFrameWithoutItsPulseOrASecondForOnePulseIsNotUsed) {
  TriggerLog log;
  for (int k = 0; k < 30; ++k) log.add(pulseUtime(k));
  auto left = std::make_shared<FakeCamera>(), right = std::make_shared<FakeCamera>();
  StereoCamera camera(liveConfig(), {ptz::test::fakeFactory(left), ptz::test::fakeFactory(right)},
                      &log);
  for (int k = 0; k < 30; ++k) {
    right->push(pulseUtime(k) + 1'000, k);
    if (k == 12) continue;
    left->push(pulseUtime(k) + 1'000, k);
    if (k == 20) left->push(pulseUtime(k) + 3'000, 100);  // twice for one pulse
  }
  left->push(pulseUtime(29) + kPeriodUs / 2, 101);  // halfway between two pulses
  const auto pairs = camera.step(pulseUtime(30));
  EXPECT_EQ(pairs.size(), 29u);  // all but pulse 12's
  for (const auto& p : pairs) EXPECT_NE(p.left.index, 100);
  const auto c = camera.counters();
  EXPECT_EQ(c.at("trigger_matched_left"), 29);
  EXPECT_EQ(c.at("trigger_unmatched_left"), 2);
  std::string message;
  EXPECT_EQ(camera.health(pulseUtime(30), &message), Health::kWarn);
  // (and no PTZ_STATE: this test sends none)
  EXPECT_EQ(message.rfind("left camera: 2 of 31 frames in the last 2.0 s answered no trigger pulse "
                          "(1 none within 8.3 ms, median distance 16.7 ms; 1 a second frame for "
                          "one pulse); frames without a PTZ_STATE",
                          0),
            0u)
      << message;
}

TEST(CameraTrigger, ParametersAreCheckedWithTheParameterNamed) {
  auto error = [](const std::vector<std::pair<std::string, std::string>>& values) {
    ptz::Params p("ptz-camera", "test");
    declareCameraParams(p);
    p.set("left_source", "0");
    p.set("right_source", "rtsp://10.0.0.2/stream");
    p.set("trigger_chip", "gpiochip0");
    p.set("trigger_line", "17");
    try {
      for (const auto& [k, v] : values) p.set(k, v);
      const CameraConfig c = cameraConfigFrom(p);
      char latencies[64];
      std::snprintf(latencies, sizeof latencies, " %g %g", c.capture[0].latency_s,
                    c.capture[1].latency_s);
      return "ok " + std::to_string(c.trigger.windowUs()) + latencies;
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
  };
  EXPECT_EQ(error({}), "ok 8333 0 0");
  EXPECT_EQ(error({{"trigger_window_s", "0.005"}}), "ok 5000 0 0");
  // Each camera may have its own latency.
  EXPECT_EQ(error({{"latency_s", "0.03"}, {"right_latency_s", "0.045"}}), "ok 8333 0.03 0.045");
  EXPECT_EQ(error({{"trigger_chip", ""}, {"right_source", "right.avi"}}), "ok 8333 0 0");
  EXPECT_EQ(error({{"right_source", "right.avi"}}),
            "parameter 'trigger_chip' is set, but right_source is a recording: only live cameras "
            "can be triggered");
  EXPECT_EQ(error({{"trigger_line", "-1"}}),
            "set: parameter 'trigger_line' must be the offset of the trigger output on "
            "'gpiochip0', got '-1'");
  EXPECT_EQ(error({{"trigger_rate_hz", "0.5"}}),
            "set: parameter 'trigger_rate_hz' must be within 1 .. 1000, got '0.5'");
  EXPECT_EQ(error({{"trigger_pulse_s", "0.02"}}),
            "set: parameter 'trigger_pulse_s' must be at most half the period (0.0166667 s), got "
            "'0.02'");
  EXPECT_EQ(error({{"trigger_window_s", "0.02"}}),
            "set: parameter 'trigger_window_s' must be below half the period (0.0166667 s), got "
            "'0.02'");
}

TEST(CameraTrigger, AfterTheWallClockIsSteppedBackPulsesAndFramesMatchAgain) {
  TriggerLog log;
  TriggerMatcher matcher(log, 8'333, 2.0);
  for (int k = 0; k < 10; ++k) log.add(pulseUtime(k));
  for (int k = 0; k < 10; ++k) {
    EXPECT_EQ(matcher.match(ptz::Side::kLeft, pulseUtime(k) + 1'000, pulseUtime(k) + 5'000),
              pulseUtime(k));
  }
  // NTP steps the clock back 5 s: the pulses and the frames' grab times both jump.
  const int64_t step_us = 5'000'000;
  for (int k = 10; k < 20; ++k) log.add(pulseUtime(k) - step_us);
  EXPECT_EQ(log.clockSteps(), 1);
  EXPECT_EQ(log.pulses(), 20);
  for (int k = 10; k < 20; ++k) {
    const int64_t t = pulseUtime(k) - step_us;
    EXPECT_EQ(matcher.match(ptz::Side::kLeft, t + 1'000, t + 5'000), t) << k;
  }
  std::map<std::string, int64_t> counters;
  matcher.addCounters(&counters);
  EXPECT_EQ(counters.at("trigger_matched_left"), 20);
  EXPECT_EQ(counters.at("trigger_unmatched_left"), 0);
  EXPECT_EQ(counters.at("trigger_clock_steps"), 1);
  EXPECT_EQ(counters.at("trigger_offset_us_p50_left"), 1'000);  // of the frames since the step
  bool error = true;
  EXPECT_EQ(matcher.problem(pulseUtime(19) - step_us + 5'000, &error), "");
  EXPECT_FALSE(error);
}

TEST(CameraTrigger, TheHintNamesTheLatencyParameterThatTheCameraUses) {
  TriggerLog log;
  for (int k = 0; k < 10; ++k) log.add(pulseUtime(k));
  TriggerMatcher matcher(log, 3'000, 2.0, {false, true});
  for (int k = 0; k < 10; ++k) {  // both 12 ms after their pulse: a latency 12 ms short
    matcher.match(ptz::Side::kLeft, pulseUtime(k) + 12'000, pulseUtime(k) + 20'000);
    matcher.match(ptz::Side::kRight, pulseUtime(k) + 12'000, pulseUtime(k) + 20'000);
  }
  bool error = false;
  const std::string message = matcher.problem(pulseUtime(9) + 20'000, &error);
  EXPECT_TRUE(error);
  EXPECT_EQ(message,
            "left camera: 10 of 10 frames in the last 2.0 s answered no trigger pulse (10 none "
            "within 3.0 ms, median distance 12.0 ms): is it in external-trigger mode and wired to "
            "the trigger line, and is latency_s its delay from the pulse?; right camera: 10 of 10 "
            "frames in the last 2.0 s answered no trigger pulse (10 none within 3.0 ms, median "
            "distance 12.0 ms): is it in external-trigger mode and wired to the trigger line, and "
            "is right_latency_s its delay from the pulse?");
}

TEST(CameraTrigger, AV4l2BufferTimeIsUsedOnlyWhenItIsPlausible) {
  const int64_t wall = 1'700'000'000'000'000;
  // 10.5 ms old on the monotonic clock: 10.5 ms before now on the wall clock.
  EXPECT_EQ(bufferTimeToWallUtime(1'000.0, 1'010.5, wall), wall - 10'500);
  EXPECT_EQ(bufferTimeToWallUtime(1'010.5, 1'010.5, wall), wall);
  EXPECT_FALSE(bufferTimeToWallUtime(0.0, 1'010.5, wall));      // no frame yet
  EXPECT_FALSE(bufferTimeToWallUtime(1'020.0, 1'010.5, wall));  // after now: another clock
  EXPECT_FALSE(bufferTimeToWallUtime(1.7e12, 1'010.5, wall));   // CLOCK_REALTIME
  EXPECT_FALSE(bufferTimeToWallUtime(5.0, 1'010.5, wall));      // older than a second
  EXPECT_FALSE(bufferTimeToWallUtime(NAN, 1'010.5, wall));
  // 24.9 days after boot a 32-bit time_t makes OpenCV's milliseconds wrap (to negative).
  const double mono_ms = 2147483648.0 + 5'000;
  EXPECT_EQ(bufferTimeToWallUtime(mono_ms - 10.5 - 4294967296.0, mono_ms, wall), wall - 10'500);
  EXPECT_FALSE(bufferTimeToWallUtime(mono_ms - 2'000 - 4294967296.0, mono_ms, wall));
}
