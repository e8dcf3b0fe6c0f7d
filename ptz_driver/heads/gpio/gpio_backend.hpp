// The parameters of the GPIO DC-motor backend (`--backend gpio`) and the two heads built from
// them. Every line offset, gain and limit is a parameter; the defaults are the Raspberry Pi 4
// wiring in the main README ("Running on hardware").
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "ptz_driver/heads/gpio/gpio_head.hpp"

namespace ptz::driver {

void declareGpioParams(Params& p);
// The configuration of head "left" or "right"; throws ConfigError naming the parameter that is
// wrong (a line used twice, a switch too close to the soft limits, a gain out of range, ...).
GpioHeadConfig gpioHeadConfig(const Params& p, const std::string& side);
// Opens the lines of one head on the chip named by `gpio_chip`.
using GpioChipOpener =
    std::function<std::unique_ptr<GpioLines>(const std::string& chip, const GpioHeadConfig& head)>;
// A real chip through libgpiod.
std::unique_ptr<GpioLines> openHeadLines(const std::string& chip, const GpioHeadConfig& head);
// Both heads, each on the lines open_chip gives it.
std::array<std::unique_ptr<PtzHead>, 2> makeGpioHeads(
    const Params& p, const GpioChipOpener& open_chip = openHeadLines);

}  // namespace ptz::driver
