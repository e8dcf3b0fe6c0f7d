// The parameters of the GPIO DC-motor backend (`--backend gpio`) and the two heads built from
// them. Every line offset, gain and limit is a parameter; the defaults are the Raspberry Pi 4
// wiring of ptz_driver/README.md.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "ptz/config.hpp"
#include "ptz_driver/gpio_fake.hpp"
#include "ptz_driver/gpio_head.hpp"

namespace ptz::driver {

void declareGpioParams(Params& p);
// The configuration of head "left" or "right"; throws ConfigError naming the parameter that is
// wrong (a line used twice, a switch too close to the soft limits, a gain out of range, ...).
GpioHeadConfig gpioHeadConfig(const Params& p, const std::string& side);
// Both heads, on the chip `gpio_chip` (libgpiod), or on simulated axes when it is "sim".
std::array<std::unique_ptr<PtzHead>, 2> makeGpioHeads(const Params& p);
// The simulated axes a configuration is wired to (gpio_chip "sim"): switches where configured,
// end stops 0.05 rad beyond them, each axis 0.3 rad inside its min switch at power-up.
std::vector<FakeAxisSpec> simulatedAxes(const GpioHeadConfig& head);
// A simulated chip of those axes on the real-time clock (gpioClockS()).
std::unique_ptr<GpioLines> simulatedChip(const GpioHeadConfig& head);

}  // namespace ptz::driver
