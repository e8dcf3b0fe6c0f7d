// A GPIO head on a simulated chip, stepped on simulated time (deterministic): the chip's physics
// advance to each time the head asked to be stepped at (PWM edges, control ticks).
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "ptz_driver/emulators/emulated_gpio_chip.hpp"
#include "ptz_driver/heads/gpio/gpio_head.hpp"

namespace ptz::test {

// Lines base .. base + 5: dir, enable, encoder A, encoder B, min switch, max switch.
inline driver::AxisConfig testAxis(const std::string& name, int base) {
  driver::AxisConfig c;
  c.name = name;
  c.param_prefix = "left_" + name + "_";
  c.lines = {base, -1, base + 1, base + 2, base + 3, base + 4, base + 5};
  c.counts_per_rad = 1000;
  c.soft_min_rad = -1;
  c.soft_max_rad = 1;
  c.min_switch_rad = -1.1;
  c.max_switch_rad = 1.1;
  c.kp_duty_per_rad = 4;
  c.kd_duty_s_per_rad = 0.15;
  c.deadband_rad = 0.002;
  c.max_duty = 0.8;
  c.pwm_hz = 1000;
  c.control_hz = 500;
  c.homing_speed_rad_s = 0.3;
  c.homing_timeout_s = 20;
  c.homing_max_lag_rad = 0.2;
  return c;
}

// The motor behind an axis: 4 rad/s at full drive, time constant 50 ms, switches where the axis
// expects them, end stops 0.1 rad beyond.
inline driver::EmulatedAxisSpec emulatedAxis(const driver::AxisConfig& c, double start_rad) {
  driver::EmulatedAxisSpec s;
  s.lines = c.lines;
  s.counts_per_rad = c.counts_per_rad;
  s.max_speed_rad_s = 4;
  s.time_constant_s = 0.05;
  s.start_rad = start_rad;
  s.min_switch_rad = c.min_switch_rad;
  s.max_switch_rad = c.max_switch_rad;
  s.min_stop_rad = c.min_switch_rad - 0.1;
  s.max_stop_rad = c.max_switch_rad + 0.1;
  return s;
}

struct GpioRig {
  // Pan on lines 0..5, tilt on 10..15; the fake is wired as `pan_spec` and `tilt_spec` say.
  GpioRig(const driver::GpioHeadConfig& config, const driver::EmulatedAxisSpec& pan_spec,
          const driver::EmulatedAxisSpec& tilt_spec) {
    auto fake = std::make_unique<driver::EmulatedGpioChip>(
        std::vector<driver::EmulatedAxisSpec>{pan_spec, tilt_spec});
    chip = fake.get();
    head = std::make_unique<driver::GpioHead>(config, std::move(fake), false);
  }

  static driver::GpioHeadConfig config() {
    driver::GpioHeadConfig c;
    c.name = "left";
    c.pan = testAxis("pan", 0);
    c.tilt = testAxis("tilt", 10);
    c.zoom = 2.5;
    return c;
  }

  // Steps for duration_s, or until done(); `each` runs after every step. Returns done().
  bool run(double duration_s, const std::function<bool()>& done = {},
           const std::function<void()>& each = {}) {
    const double end_s = t_s + duration_s;
    while (t_s < end_s) {
      chip->advanceTo(t_s);
      const double next_s = head->step(t_s);
      if (each) each();
      if (done && done()) return true;
      t_s = std::min(next_s, end_s);
    }
    return !done || done();
  }

  driver::EmulatedGpioChip* chip = nullptr;
  std::unique_ptr<driver::GpioHead> head;
  double t_s = 0;
};

}  // namespace ptz::test
