// ptz-control's parameters (all but the transport's, which the main declares first): their
// declarations, in the order --help lists them, and the controller and delay monitor they make.
#pragma once

#include "common/config.hpp"
#include "control/controller/controller.hpp"
#include "control/controller/delay_monitor.hpp"

namespace ptz::control {

void declareControlParams(Params& p);
// The controller's parameters; throws ConfigError for a bad mode or a search region outside the
// axis limits.
ControllerParams controllerParamsFrom(const Params& p);
// The live delay monitor: the paper's loop model of the pan axis and, in smith mode, the delay
// the model assumes.
DelayMonitor delayMonitorFrom(const Params& p);

}  // namespace ptz::control
