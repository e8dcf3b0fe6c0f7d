#include "ptz_driver/heads/gpio/gpio_backend.hpp"

#include <cmath>
#include <cstdio>
#include <map>

#include "common/measure.hpp"
#include "common/plant.hpp"

namespace ptz::driver {
namespace {

// Raspberry Pi 4, BCM numbers on gpiochip0 (README): dir, dir2, enable, A, B, min, max.
struct PiAxis {
  const char* head;
  const char* axis;
  std::array<int, 7> lines;
};
const PiAxis kPiLines[4] = {{"left", "pan", {5, -1, 12, 17, 27, 2, 3}},
                            {"left", "tilt", {6, -1, 13, 22, 23, 4, 7}},
                            {"right", "pan", {20, -1, 18, 24, 25, 8, 9}},
                            {"right", "tilt", {21, -1, 19, 10, 11, 26, 16}}};
const char* const kLineNames[7] = {"dir_line",       "dir2_line",      "enable_line",
                                   "encoder_a_line", "encoder_b_line", "limit_min_line",
                                   "limit_max_line"};

constexpr int kMaxLine = 4095;

}  // namespace

void declareGpioParams(Params& p) {
  p.add("gpio_chip", "gpiochip0",
        "backend gpio: GPIO chip (name, number, /dev path or label; sim: simulated axes)");
  const Range rate = Range::above(0).andAtMost(20000);
  p.add("pwm_hz", 1000.0, "Hz", "backend gpio: software PWM frequency of the enable lines", rate);
  p.add("control_hz", 500.0, "Hz", "backend gpio: position controller rate", rate);
  p.add("max_duty", 0.8, "", "backend gpio: largest PWM duty cycle", Range::above(0).andAtMost(1));
  p.add("min_duty", 0.0, "", "backend gpio: duty the motors need to start turning",
        Range::between(0, 1));
  p.addOrder("min_duty", "max_duty", false);
  p.add("homing_timeout_s", 30.0, "s", "backend gpio: homing fails after this long",
        Range::above(0));
  p.add("homing_max_lag_rad", 0.2, "rad",
        "backend gpio: homing fails when an axis lags its ramp by more (motor or encoder wrong)",
        Range::above(0));
  p.add("gpio_zoom", 1.0, "ratio", "backend gpio: the zoom the heads report (no zoom motor)",
        Range::above(0));
  p.add("coast_rad", 0.16, "rad",
        "backend gpio: how far an axis runs on when its drive is cut at full speed (speed x the "
        "motor's time constant); the switches must lie at least this far outside the soft limits",
        Range::atLeast(0));
  // At least coast_rad outside the default soft limits (+-170 deg pan, -30..90 deg tilt).
  const double switch_rad[2][2] = {{-3.15, 3.15}, {-0.7, 1.75}};
  const double homing_rad_s[2] = {0.3, 0.2};
  for (int i = 0; i < 2; ++i) {
    const std::string a = i == 0 ? "pan" : "tilt";
    p.add(a + "_counts_per_rad", 1000.0, "1/rad",
          "backend gpio: " + a + " encoder counts (x4) per radian, up toward max", Range::above(0));
    p.add(a + "_kp", 4.0, "1/rad", "backend gpio: " + a + " duty per radian of error",
          Range::above(0));
    p.add(a + "_kd", 0.15, "s/rad", "backend gpio: " + a + " duty per rad/s of speed (damping)",
          Range::atLeast(0));
    p.add(a + "_deadband_rad", 0.002, "rad", "backend gpio: " + a + " error that leaves it off",
          Range::between(0, 1));
    const Range position = Range::between(-6.3, 6.3);  // as the soft limits
    p.add(a + "_min_switch_rad", switch_rad[i][0], "rad",
          "backend gpio: " + a + " position where the min switch closes (homing reference)",
          position);
    p.add(a + "_max_switch_rad", switch_rad[i][1], "rad",
          "backend gpio: " + a + " position where the max switch closes", position);
    p.add(a + "_homing_speed_rad_s", homing_rad_s[i], "rad/s",
          "backend gpio: " + a + " speed toward the min switch and back to 0", Range::above(0));
  }
  const char* const what[7] = {"direction line (high: toward max)",
                               "second direction line, not dir, for IN1/IN2 bridges (-1: none)",
                               "enable line (software PWM)",
                               "encoder A line",
                               "encoder B line",
                               "min limit switch line (closed: low)",
                               "max limit switch line (closed: low)"};
  for (const auto& a : kPiLines) {
    const std::string prefix = std::string(a.head) + "_" + a.axis + "_";
    for (size_t k = 0; k < 7; ++k) {
      p.add(prefix + kLineNames[k], a.lines[k], "",
            "backend gpio: " + std::string(a.head) + " " + a.axis + " " + what[k],
            Range::between(k == 1 ? -1 : 0, kMaxLine));
    }
  }
}

GpioHeadConfig gpioHeadConfig(const Params& p, const std::string& side) {
  const PtzPlant::Params plant = axisLimitsFrom(p);
  GpioHeadConfig head;
  head.name = side;
  // The numbers are within their declared ranges; what depends on another is checked here.
  head.zoom = p.getDouble("gpio_zoom");
  for (int i = 0; i < 2; ++i) {
    const std::string a = i == 0 ? "pan" : "tilt";
    AxisConfig& c = i == 0 ? head.pan : head.tilt;
    c.name = a;
    c.param_prefix = side + "_" + a + "_";
    int* lines[7] = {&c.lines.dir,       &c.lines.dir2,      &c.lines.enable,   &c.lines.encoder_a,
                     &c.lines.encoder_b, &c.lines.limit_min, &c.lines.limit_max};
    for (int k = 0; k < 7; ++k) {
      const std::string name = c.param_prefix + kLineNames[k];
      *lines[k] = p.getInt(name);
    }
    c.counts_per_rad = p.getDouble(a + "_counts_per_rad");
    c.kp_duty_per_rad = p.getDouble(a + "_kp");
    c.kd_duty_s_per_rad = p.getDouble(a + "_kd");
    c.deadband_rad = p.getDouble(a + "_deadband_rad");
    c.homing_speed_rad_s = p.getDouble(a + "_homing_speed_rad_s");
    c.soft_min_rad = plant.axis[i].min_position;
    c.soft_max_rad = plant.axis[i].max_position;
    c.min_switch_rad = p.getDouble(a + "_min_switch_rad");
    c.max_switch_rad = p.getDouble(a + "_max_switch_rad");
    // Stopped at a soft limit from full speed, an axis coasts on: it must come to rest before
    // the switch, not run through it toward the mechanical stop beyond.
    const double coast_rad = p.getDouble("coast_rad");
    const double margin_rad[2] = {c.soft_min_rad - c.min_switch_rad,
                                  c.max_switch_rad - c.soft_max_rad};
    for (int end = 0; end < 2; ++end) {
      if (margin_rad[end] >= coast_rad && margin_rad[end] > 0) continue;  // false for NaN
      const std::string sw = a + (end == 0 ? "_min_switch_rad" : "_max_switch_rad");
      const std::string soft = a + (end == 0 ? "_min" : "_max");
      throw p.invalid(sw, "must lie at least 'coast_rad' (" + formatNumber(coast_rad) + ") " +
                              (end == 0 ? "below" : "above") + " the soft limit '" + soft + "' (" +
                              formatNumber(end == 0 ? c.soft_min_rad : c.soft_max_rad) +
                              "), so that an axis stopped there coasts to rest before the switch");
    }
    c.pwm_hz = p.getDouble("pwm_hz");
    c.control_hz = p.getDouble("control_hz");
    c.max_duty = p.getDouble("max_duty");
    c.min_duty = p.getDouble("min_duty");
    c.homing_timeout_s = p.getDouble("homing_timeout_s");
    c.homing_max_lag_rad = p.getDouble("homing_max_lag_rad");
  }
  return head;
}

std::array<std::unique_ptr<PtzHead>, 2> makeGpioHeads(const Params& p,
                                                      const GpioChipOpener& open_chip) {
  std::array<GpioHeadConfig, 2> configs = {gpioHeadConfig(p, "left"), gpioHeadConfig(p, "right")};
  // One line, one use: a clear error here instead of "busy" from the kernel.
  std::map<int, std::string> used;
  for (const auto& side : {"left_", "right_"}) {
    for (const auto& a : {"pan_", "tilt_"}) {
      for (const char* k : kLineNames) {
        const std::string name = std::string(side) + a + k;
        const int line = p.getInt(name);
        if (line < 0) continue;
        const auto [it, fresh] = used.emplace(line, name);
        if (!fresh) {
          throw ConfigError("parameters '" + it->second + "' and '" + name + "' both use line " +
                            std::to_string(line));
        }
      }
    }
  }
  const std::string chip = p.getString("gpio_chip");
  std::array<std::unique_ptr<PtzHead>, 2> heads;
  for (size_t i = 0; i < 2; ++i) {
    auto lines = open_chip(chip, configs[i]);
    heads[i] = std::make_unique<GpioHead>(configs[i], std::move(lines), true);
  }
  return heads;
}

std::unique_ptr<GpioLines> openHeadLines(const std::string& chip, const GpioHeadConfig&) {
  return openGpiodChip(chip, "ptz-driver");
}

}  // namespace ptz::driver
