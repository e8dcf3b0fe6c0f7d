// The heads ptz-driver drives, chosen by the `backend` parameter: each backend's parameters
// are declared here, and the two heads (left, right) are built from them.
#pragma once

#include <array>
#include <memory>

#include "common/config.hpp"
#include "ptz_driver/heads/common/head.hpp"
#include "ptz_driver/heads/gpio/gpio_backend.hpp"

namespace ptz::driver {

void declareBackendParams(Params& p);
// Throws ConfigError naming the parameter (or file and field) that is wrong. GPIO heads get their
// lines from open_gpio.
std::array<std::unique_ptr<PtzHead>, 2> makeHeads(const Params& p,
                                                  const GpioChipOpener& open_gpio = openHeadLines);

// Heads that take and report the camera's own units, for measuring the angle map a model file
// should hold (ptz-head-calibrate): PtzPose's pan_rad is the pan unit, tilt_rad the tilt unit and
// zoom 1 + the zoom unit; the model file named by the parameters gives only its ranges, speeds
// and wire settings. Backends onvif, visca_ip and visca_serial (the others have no position
// units to map); throws ConfigError otherwise.
std::array<std::unique_ptr<PtzHead>, 2> makeUnitHeads(const Params& p);

}  // namespace ptz::driver
