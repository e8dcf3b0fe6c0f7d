#include "ptz_driver/emulators/emulated_gpio_wiring.hpp"

#include "ptz_driver/heads/gpio/gpio_backend.hpp"

namespace ptz::driver {

std::vector<EmulatedAxisSpec> emulatedAxes(const GpioHeadConfig& head) {
  std::vector<EmulatedAxisSpec> axes;
  for (const AxisConfig* c : {&head.pan, &head.tilt}) {
    EmulatedAxisSpec s;
    s.lines = c->lines;
    s.counts_per_rad = c->counts_per_rad;
    s.min_switch_rad = c->min_switch_rad;
    s.max_switch_rad = c->max_switch_rad;
    s.min_stop_rad = c->min_switch_rad - 0.05;
    s.max_stop_rad = c->max_switch_rad + 0.05;
    s.start_rad = c->min_switch_rad + 0.3;
    axes.push_back(s);
  }
  return axes;
}

std::unique_ptr<GpioLines> emulatedChip(const GpioHeadConfig& head) {
  auto chip = std::make_unique<EmulatedGpioChip>(emulatedAxes(head));
  chip->useClock(gpioClockS);
  return chip;
}

std::unique_ptr<GpioLines> openHeadLinesOrEmulated(const std::string& chip,
                                                   const GpioHeadConfig& head) {
  return chip == "sim" ? emulatedChip(head) : openHeadLines(chip, head);
}

}  // namespace ptz::driver
