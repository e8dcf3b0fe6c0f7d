// The GPIO backend at its edges: libgpiod errors that name the chip, parameters checked with
// errors that name them, ptz-driver exiting 2 on a chip that does not exist, and heads in real
// time on the simulated chip (the control thread, the PWM duty it achieves, how late it wakes).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "ptz/plant.hpp"
#include "ptz_driver/gpio_factory.hpp"
#include "ptz_driver/head_factory.hpp"
#include "support/gpio_rig.hpp"

using ptz::ConfigError;
using ptz::PtzPose;
using namespace ptz::driver;

namespace {

void declare(ptz::Params& p) {
  ptz::addPlantParams(p);
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

// Polls until done() or the timeout (the head runs on its own thread).
bool waitFor(const std::function<bool()>& done, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

std::string run(const std::string& command) {
  std::string out;
  FILE* f = popen(command.c_str(), "r");
  char buf[512];
  while (f && std::fgets(buf, sizeof buf, f)) out += buf;
  if (f) pclose(f);
  return out;
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
    p.set(name, value);
    const std::string what = errorOf(p);
    for (const auto& n : named) EXPECT_NE(what.find(n), std::string::npos) << what;
  };
  expectError("left_tilt_enable_line", "12", {"left_pan_enable_line", "left_tilt_enable_line"});
  expectError("right_pan_encoder_a_line", "-1", {"right_pan_encoder_a_line"});
  expectError("pan_min_switch_rad", "-2.0", {"pan_min_switch_rad", "pan_min"});
  expectError("max_duty", "1.5", {"max_duty"});
  expectError("tilt_counts_per_rad", "0", {"tilt_counts_per_rad"});
  expectError("gpio_chip", "/dev/gpiochip99", {"'/dev/gpiochip99'"});
  expectError("backend", "gpoi", {"'gpoi'", "gpio"});
}

TEST(GpioBackend, DriverExitsTwoNamingAChipThatDoesNotExist) {
  const std::string driver = std::string("timeout 20 ") + PTZ_DRIVER_BIN;
  std::string out = run(driver + " --backend gpio --gpio-chip /dev/gpiochip99 --lcm-url memq:// " +
                        "2>&1; echo exit=$?");
  EXPECT_NE(out.find("'/dev/gpiochip99'"), std::string::npos) << out;
  EXPECT_NE(out.find("exit=2"), std::string::npos) << out;
  // The example configuration parses, and says the same about the chip.
  out = run(driver + " --config " PTZ_SOURCE_DIR "/config/driver_gpio.yaml --gpio-chip gpiochip9" +
            " --lcm-url memq:// 2>&1; echo exit=$?");
  EXPECT_NE(out.find("cannot open GPIO chip 'gpiochip9'"), std::string::npos) << out;
  EXPECT_NE(out.find("exit=2"), std::string::npos) << out;
}

TEST(GpioBackend, BothHeadsHomeInRealTimeOnTheSimulatedChip) {
  ptz::Params p("test", "test");
  declare(p);
  p.set("gpio_chip", "sim");
  auto heads = makeHeads(p);
  for (auto& h : heads) h->start(0);
  // 0.3 rad to the min switch at 0.3 rad/s (pan) and 0.2 rad/s (tilt): 1 and 1.5 s.
  ASSERT_TRUE(waitFor([&] { return heads[0]->measured() && heads[1]->measured(); }, 5));
  for (auto& h : heads) {
    // Tilt just found its switch; pan found its own 0.5 s ago and is on its way back to 0.
    EXPECT_NEAR(h->measured()->tilt_rad, -0.6, 0.01);
    EXPECT_GT(h->measured()->pan_rad, -3.05);
    EXPECT_LT(h->measured()->pan_rad, -3.05 + 0.3);
    EXPECT_EQ(h->fd(), -1);
    EXPECT_EQ(h->stats().errors, 0) << h->stats().last_error;
    h->command(PtzPose{-2.5, 0.2, 1}, 0);
  }
  // Commanded on their threads: there within 3 counts (the default 1000 counts/rad).
  auto there = [&](const PtzHead& h) {
    return std::abs(h.measured()->pan_rad + 2.5) <= 3e-3 &&
           std::abs(h.measured()->tilt_rad - 0.2) <= 3e-3;
  };
  EXPECT_TRUE(waitFor([&] { return there(*heads[0]) && there(*heads[1]); }, 3));
}

TEST(GpioBackend, ControlThreadPwmAndItsTiming) {
  auto c = ptz::test::GpioRig::config();
  c.pan.max_duty = c.tilt.max_duty = 0.3;
  auto fake = std::make_unique<FakeGpio>(std::vector<FakeAxisSpec>{
      ptz::test::fakeAxis(c.pan, -1.0), ptz::test::fakeAxis(c.tilt, -1.0)});
  FakeGpio* chip = fake.get();
  chip->useClock(gpioClockS);
  GpioHead head(c, std::move(fake), true);
  head.start(0);
  ASSERT_TRUE(waitFor([&] { return head.measured().has_value(); }, 3));
  head.command(PtzPose{0.9, 0, 1}, 0);
  // Saturated at duty 0.3 (1.2 rad/s) all the way: measure between -0.9 and -0.3 rad.
  ASSERT_TRUE(waitFor([&] { return chip->positionRad(0) > -0.9; }, 3));
  head.takeWakeLatenessS();
  const double t0 = chip->nowS(), high0 = chip->highTimeS(1);
  const int64_t rises0 = chip->risingEdges(1);
  ASSERT_TRUE(waitFor([&] { return chip->positionRad(0) > -0.3; }, 3));
  const double t1 = chip->nowS(), high1 = chip->highTimeS(1);
  const int64_t rises1 = chip->risingEdges(1);
  std::vector<double> late_s = head.takeWakeLatenessS();
  std::sort(late_s.begin(), late_s.end());
  const double duty = (high1 - high0) / (t1 - t0), pwm_hz = (rises1 - rises0) / (t1 - t0);
  std::printf(
      "software PWM, commanded 1000 Hz at duty 0.300: %.0f Hz, duty %.4f over %.2f s; "
      "steps run late by p1 %.0f us, p50 %.0f us, p99 %.0f us, max %.0f us (%zu steps)\n",
      pwm_hz, duty, t1 - t0, late_s[late_s.size() / 100] * 1e6, late_s[late_s.size() / 2] * 1e6,
      late_s[late_s.size() * 99 / 100] * 1e6, late_s.back() * 1e6, late_s.size());
  // Loose bounds: the machine's other load sets the jitter (README: what it achieves).
  EXPECT_NEAR(duty, 0.3, 0.1);
  EXPECT_GT(pwm_hz, 500);
  EXPECT_LE(pwm_hz, 1001);
  // Stop: the enable line low at once and for good.
  head.stop(0, 0.1);
  EXPECT_FALSE(chip->level(1));
  const double stopped_s = chip->nowS(), high_at_stop = chip->highTimeS(1);
  ASSERT_TRUE(waitFor([&] { return chip->nowS() > stopped_s + 0.2; }, 3));
  EXPECT_EQ(chip->highTimeS(1), high_at_stop);
  EXPECT_FALSE(chip->level(1));
}
