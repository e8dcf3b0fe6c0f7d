// GPIO heads without hardware (gpio_chip "sim"): each head on an emulated chip wired as its
// configuration says.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ptz_driver/emulators/emulated_gpio_chip.hpp"
#include "ptz_driver/heads/gpio/gpio_head.hpp"

namespace ptz::driver {

// The simulated axes a configuration is wired to: switches where configured, end stops 0.05 rad
// beyond them, each axis 0.3 rad inside its min switch at power-up.
std::vector<EmulatedAxisSpec> emulatedAxes(const GpioHeadConfig& head);
// A simulated chip of those axes on the real-time clock (gpioClockS()).
std::unique_ptr<GpioLines> emulatedChip(const GpioHeadConfig& head);
// For ptz-driver's gpio backend: the emulated chip for "sim", else the real chip.
std::unique_ptr<GpioLines> openHeadLinesOrEmulated(const std::string& chip,
                                                   const GpioHeadConfig& head);

}  // namespace ptz::driver
