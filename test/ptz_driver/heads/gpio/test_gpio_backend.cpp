// The GPIO backend at its edges: libgpiod errors that name the chip, parameters checked with
// errors that name them, ptz-driver exiting 2 on a chip that does not exist, and heads in real
// time on the simulated chip (the control thread, the PWM duty it achieves, how late it wakes);
// the simulated axes of the default configuration homing, stepped.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <numeric>

#include "common/plant.hpp"
#include "ptz_driver/emulators/emulated_gpio_wiring.hpp"
#include "ptz_driver/heads/gpio/gpio_backend.hpp"
#include "ptz_driver/heads/head_factory.hpp"
#include "support/child_process.hpp"
#include "support/hardware/gpio_rig.hpp"

using ptz::ConfigError;
using ptz::PtzPose;
using namespace ptz::driver;

namespace {

void declare(ptz::Params& p) {
  ptz::addAxisLimitParams(p);
  declareBackendParams(p);
  p.set("backend", "gpio");
}

std::string errorOf(const ptz::Params& p) {
  try {
    makeHeads(p);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(GpioBackend, AChipThatDoesNotExistIsAnErrorNamingIt) {
  for (const std::string chip : {"gpiochip9", "/dev/gpiochip99", "/dev/null", "no-such-label"}) {
    try {
      openGpiodChip(chip, "test");
      ADD_FAILURE() << chip << " opened";
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("'" + chip + "'"), std::string::npos) << what;
      EXPECT_NE(what.find("gpio_chip"), std::string::npos) << what;
    }
  }
}

TEST(GpioBackend, ParametersAreCheckedWithErrorsNamingThem) {
  auto expectError = [](const std::string& name, const std::string& value,
                        const std::vector<std::string>& named) {
    ptz::Params p("test", "test");
    declare(p);
    std::string what;
    try {
      p.set(name, value);  // a value out of its range is refused here already
      what = errorOf(p);
    } catch (const ConfigError& e) {
      what = e.what();
    }
    for (const auto& n : named) EXPECT_NE(what.find(n), std::string::npos) << what;
  };
  expectError("left_tilt_enable_line", "12", {"left_pan_enable_line", "left_tilt_enable_line"});
  expectError("right_pan_encoder_a_line", "-1", {"right_pan_encoder_a_line"});
  expectError("pan_min_switch_rad", "-2.0", {"pan_min_switch_rad", "pan_min"});
  // Closer to the soft limits than an axis coasts (pan_max 2.967, tilt_min -0.524).
  expectError("pan_max_switch_rad", "3.05",
              {"'pan_max_switch_rad' must lie", "'pan_max'", "'coast_rad' (0.16)", "got '3.05'"});
  expectError("tilt_min_switch_rad", "-0.6", {"'tilt_min_switch_rad'", "'tilt_min'"});
  expectError("coast_rad", "-1", {"coast_rad"});
  expectError("max_duty", "1.5", {"max_duty"});
  expectError("tilt_counts_per_rad", "0", {"tilt_counts_per_rad"});
  expectError("gpio_chip", "/dev/gpiochip99", {"'/dev/gpiochip99'"});
  expectError("backend", "gpoi", {"'gpoi'", "gpio"});
}

TEST(GpioBackend, DriverExitsTwoNamingAChipThatDoesNotExist) {
  const std::string driver = std::string("timeout 20 ") + PTZ_DRIVER_BIN;
  std::string out = ptz::test::runShell(
      driver + " --backend gpio --gpio-chip /dev/gpiochip99 --lcm-url memq:// " +
      "2>&1; echo exit=$?");
  EXPECT_NE(out.find("'/dev/gpiochip99'"), std::string::npos) << out;
  EXPECT_NE(out.find("exit=2"), std::string::npos) << out;
  // The example configuration parses, and says the same about the chip.
  out = ptz::test::runShell(
      driver + " --config " PTZ_SOURCE_DIR "/config/driver_gpio.yaml --gpio-chip gpiochip9" +
      " --lcm-url memq:// 2>&1; echo exit=$?");
  EXPECT_NE(out.find("cannot open GPIO chip 'gpiochip9'"), std::string::npos) << out;
  EXPECT_NE(out.find("exit=2"), std::string::npos) << out;
}

TEST(GpioBackend, TheSimulatedAxesHomeAtTheConfiguredSwitches) {
  ptz::Params p("test", "test");
  declare(p);
  const GpioHeadConfig config = gpioHeadConfig(p, "left");
  const std::vector<EmulatedAxisSpec> axes = emulatedAxes(config);
  ASSERT_EQ(axes.size(), 2u);
  ptz::test::GpioRig rig(config, axes[0], axes[1]);  // stepped: positions known at each step
  rig.head->start(0);
  // 0.3 rad to the min switch at 0.3 rad/s (pan) and 0.2 rad/s (tilt): 1 and 1.5 s.
  ASSERT_TRUE(rig.run(5, [&] { return rig.head->measured().has_value(); }));
  EXPECT_NEAR(rig.t_s, 1.6, 0.1);
  constexpr double kCount = 1e-3;  // rad: 1000 counts/rad by default
  // Tilt just found its switch; pan found its own 0.5 s ago and is on its way back to 0.
  EXPECT_NEAR(rig.chip->positionRad(1), -0.7, 0.01);
  EXPECT_NEAR(rig.head->measured()->tilt_rad, rig.chip->positionRad(1), 1.5 * kCount);
  EXPECT_NEAR(rig.head->measured()->pan_rad, rig.chip->positionRad(0), 1.5 * kCount);
  EXPECT_GT(rig.head->measured()->pan_rad, -3.15);
  EXPECT_LT(rig.head->measured()->pan_rad, -3.15 + 0.3);
  EXPECT_EQ(rig.head->stats().errors, 0) << rig.head->stats().last_error;
}

TEST(GpioBackend, BothHeadsHomeInRealTimeOnTheSimulatedChip) {
  ptz::Params p("test", "test");
  declare(p);
  p.set("gpio_chip", "sim");
  auto heads = makeHeads(p, openHeadLinesOrEmulated);
  for (auto& h : heads) h->start(0);
  // Looked at after each step of the left head's thread (both step every millisecond).
  const auto& left = dynamic_cast<const GpioHead&>(*heads[0]);
  // 0.3 rad to the min switch at 0.3 rad/s (pan) and 0.2 rad/s (tilt): 1 and 1.5 s.
  ASSERT_TRUE(left.waitForStep([&] { return heads[0]->measured() && heads[1]->measured(); }, 5));
  for (auto& h : heads) {
    // Homed, and on the way from the switches back to 0 (at 0.3 and 0.2 rad/s: 10 and 3.5 s);
    // where exactly depends on when this thread ran (the stepped test above has the numbers).
    const PtzPose at = *h->measured();
    EXPECT_GE(at.pan_rad, -3.15 - 0.01);
    EXPECT_LE(at.pan_rad, 0.003);
    EXPECT_GE(at.tilt_rad, -0.7 - 0.01);
    EXPECT_LE(at.tilt_rad, 0.003);
    EXPECT_EQ(h->fd(), -1);
    EXPECT_EQ(h->stats().errors, 0) << h->stats().last_error;
    h->command(PtzPose{-2.5, 0.2, 1}, 0);
  }
  // Commanded on their threads: there within 3 counts (the default 1000 counts/rad).
  auto there = [&](const PtzHead& h) {
    return std::abs(h.measured()->pan_rad + 2.5) <= 3e-3 &&
           std::abs(h.measured()->tilt_rad - 0.2) <= 3e-3;
  };
  EXPECT_TRUE(left.waitForStep([&] { return there(*heads[0]) && there(*heads[1]); }, 3));
}

TEST(GpioBackend, ControlThreadPwmAndItsTiming) {
  auto c = ptz::test::GpioRig::config();
  c.pan.max_duty = c.tilt.max_duty = 0.3;
  auto fake = std::make_unique<EmulatedGpioChip>(std::vector<EmulatedAxisSpec>{
      ptz::test::emulatedAxis(c.pan, -1.0), ptz::test::emulatedAxis(c.tilt, -1.0)});
  EmulatedGpioChip* chip = fake.get();
  chip->useClock(gpioClockS);
  GpioHead head(c, std::move(fake), true);
  head.start(0);
  ASSERT_TRUE(head.waitForStep([&] { return head.measured().has_value(); }, 3));
  head.command(PtzPose{0.9, 0, 1}, 0);
  // Saturated at duty 0.3 (1.2 rad/s) all the way: measure between -0.9 and -0.3 rad.
  ASSERT_TRUE(head.waitForStep([&] { return chip->positionRad(0) > -0.9; }, 3));
  head.takeWakeLatenessS();
  head.takeEdgeErrorBoundsS();
  const EmulatedGpioChip::OutputTally from = chip->tally(1);
  ASSERT_TRUE(head.waitForStep([&] { return chip->positionRad(0) > -0.3; }, 3));
  const EmulatedGpioChip::OutputTally to = chip->tally(1);
  std::vector<double> late_s = head.takeWakeLatenessS();
  const std::vector<double> edge_error_s = head.takeEdgeErrorBoundsS();
  const double edge_error_sum_s = std::accumulate(edge_error_s.begin(), edge_error_s.end(), 0.0);
  std::sort(late_s.begin(), late_s.end());
  const double window_s = to.at_s - from.at_s;
  const double duty = (to.high_s - from.high_s) / window_s;
  const double pwm_hz = static_cast<double>(to.rising - from.rising) / window_s;
  std::printf(
      "software PWM, commanded 1000 Hz at duty 0.300: %.0f Hz, duty %.4f over %.2f s; "
      "steps run late by p1 %.0f us, p50 %.0f us, p99 %.0f us, max %.0f us (%zu steps); "
      "edges off by %.1f ms at most in all\n",
      pwm_hz, duty, window_s, late_s[late_s.size() / 100] * 1e6, late_s[late_s.size() / 2] * 1e6,
      late_s[late_s.size() * 99 / 100] * 1e6, late_s.back() * 1e6, late_s.size(),
      edge_error_sum_s * 1e3);
  // The machine's other load moves the edges (README: what it achieves); each edge by at most
  // its step's bound, and a period at either end of the window is cut. So the high time is off
  // by no more than that, and no more periods are lost than that much time holds (on a quiet
  // machine a few ms over the window: the duty within ~0.03).
  const double period_s = 1e-3;
  EXPECT_LE(std::abs(duty - 0.3) * window_s, edge_error_sum_s + 2 * period_s) << duty;
  EXPECT_GE(static_cast<double>(to.rising - from.rising),
            (window_s - edge_error_sum_s) / period_s - 2);
  // Never faster than 1 kHz: one rise per period at most, and a period's rise may fall at
  // either end of the window, so up to 1000 W + 1 rises in W seconds.
  EXPECT_LE(pwm_hz, 1000 + 1 / window_s + 1e-9);
  // Stop: the enable line low at once and for good.
  head.stop(0, 0.1);
  EXPECT_FALSE(chip->level(1));
  const double stopped_s = chip->nowS(), high_at_stop = chip->highTimeS(1);
  ASSERT_TRUE(head.waitForStep([&] { return chip->nowS() > stopped_s + 0.2; }, 3));
  EXPECT_EQ(chip->highTimeS(1), high_at_stop);
  EXPECT_FALSE(chip->level(1));
}
