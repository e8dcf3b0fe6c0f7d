// ptz-driver --discover: finds the ONVIF cameras on the network (WS-Discovery) and prints one
// line per camera, then, with the onvif backend's credentials, each media profile's RTSP stream
// and the ptz-camera flag that points at it. No LCM: it runs before the driver would open it.
#pragma once

#include <cstdio>
#include <optional>

#include "common/config.hpp"

namespace ptz::driver {

// discover, discover_timeout_ms, discover_ttl, discover_interface.
void declareDiscoverParams(Params& p);

// Parses the flags; nullopt when --discover was not given (the driver then runs as usual), else
// the exit code: 0 cameras found (and listed), 1 none answered, 2 a bad parameter, 4 a camera's
// streams could not be listed (stderr names the camera and the operation).
std::optional<int> runDiscoverIfAsked(int argc, char** argv, Params& p);

// The discovery itself on parsed parameters; the report on out, problems on err.
int runDiscover(const Params& p, std::FILE* out, std::FILE* err);

}  // namespace ptz::driver
