// ptz-driver with the GPIO backend as a process, on the simulated chip (--gpio-chip sim) with
// the example configuration: PTZ_STATE once both heads are homed, setpoints followed to within
// a few encoder counts, the fixed zoom reported, the deadman hold, a clean exit on SIGTERM.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>

#include "common/transport/transport.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;

namespace {

struct Listener {
  void onState(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::ptz_state_t* m) {
    last = *m;
    ++states;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    if (m->process != "ptz-driver") return;
    up = true;
    ++statuses;
    state = m->state;
    message = m->message;
    for (const auto& c : m->counters) counters[c.name] = c.value;
  }
  ptzstereo::ptz_state_t last{};
  int64_t states = 0;
  bool up = false;
  int64_t statuses = 0;
  int8_t state = -1;
  std::string message;
  std::map<std::string, int64_t> counters;
};

}  // namespace

TEST(GpioDriver, FollowsSetpointsHoldsAndStopsOnTheSimulatedChip) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Listener l;
  lcm.subscribe("PTZ_STATE", &Listener::onState, &l);
  lcm.subscribe("PROCESS_STATUS_PTZ_DRIVER", &Listener::onStatus, &l);
  ptz::test::ChildProcess driver({PTZ_DRIVER_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                                  PTZ_SOURCE_DIR "/config/driver_gpio.yaml", "--gpio-chip", "sim"});
  // Homing: 0.3 rad to the min switches at 0.3 (pan) and 0.2 rad/s (tilt), about 1.6 s.
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.states > 0; }, 10s));
  // Homed at the switch (-0.7) and on the way back to 0: where exactly depends on when the
  // first state came (ptz_heads_tests has the exact numbers, stepped).
  for (const auto& head : {l.last.left, l.last.right}) {
    EXPECT_GE(head.tilt_rad, -0.7 - 0.01);
    EXPECT_LE(head.tilt_rad, 0.003);
  }
  EXPECT_DOUBLE_EQ(l.last.left.zoom, 1.0);  // gpio_zoom: there is no zoom motor
  // Setpoints at 50 Hz until both heads are within 3 counts (1018.6 counts/rad).
  auto there = [&] {
    return std::abs(l.last.left.pan_rad + 2.5) <= 3e-3 &&
           std::abs(l.last.left.tilt_rad - 0.1) <= 3e-3 &&
           std::abs(l.last.right.pan_rad + 2.6) <= 3e-3 &&
           std::abs(l.last.right.tilt_rad - 0.2) <= 3e-3;
  };
  auto followUntil = [&](const std::function<bool()>& done, std::chrono::seconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!done() && std::chrono::steady_clock::now() < deadline) {
      ptzstereo::ptz_setpoint_t sp{};
      sp.utime = sp.publish_utime = ptz::wallUtime();
      sp.left = {-2.5, 0.1, 4.0};
      sp.right = {-2.6, 0.2, 4.0};
      lcm.publish("PTZ_SETPOINT", &sp);
      lcm.handleTimeout(20);
    }
    return done();
  };
  ASSERT_TRUE(followUntil(there, 10s)) << l.last.left.pan_rad << " " << l.last.left.tilt_rad << " "
                                       << l.last.right.pan_rad << " " << l.last.right.tilt_rad;
  EXPECT_DOUBLE_EQ(l.last.right.zoom, 1.0);
  // Healthy while it follows: a status published after the heads arrived, setpoints still coming
  // (once they stop, the status says so within a second: WARN, "no PTZ_SETPOINT for 1 s").
  const int64_t statuses = l.statuses;
  ASSERT_TRUE(followUntil([&] { return l.statuses >= statuses + 2; }, 10s));
  EXPECT_EQ(l.state, ptzstereo::process_status_t::STATE_OK) << l.message;
  ASSERT_TRUE(l.counters.count("head_errors") && l.counters.count("head_malformed"));
  EXPECT_EQ(l.counters["head_errors"], 0);
  EXPECT_EQ(l.counters["head_malformed"], 0);
  // No more setpoints: the deadman holds them where they are.
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return l.counters["deadman_holds"] >= 1; }, 5s));
  const int64_t n = l.states;
  ptz::test::handleUntil(
      lcm, [&] { return l.states >= n + 50; }, 5s);  // a second of states
  EXPECT_TRUE(there());
  EXPECT_EQ(l.counters["head_errors"], 0);
  EXPECT_EQ(l.counters["head_malformed"], 0);
  EXPECT_EQ(driver.stop(), 0) << "SIGTERM: the driver stops the motors and exits cleanly";
}
