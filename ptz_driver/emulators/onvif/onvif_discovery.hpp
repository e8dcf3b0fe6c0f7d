// A camera's side of WS-Discovery (2005/04, as ONVIF uses it) on bytes alone: a Probe read with
// libxml2's limits (xml.hpp: size, depth, no DTD), and the ProbeMatches that answers it. ptz-sim's
// responder (sim/onvif/discovery_responder.*) carries them over UDP.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace ptz::driver {

// Longest MessageID taken from a Probe (a urn:uuid is 45 characters).
constexpr std::size_t kMaxProbeMessageIdChars = 256;

struct ProbeRead {
  bool ok = false;
  std::string message_id;  // the Probe's, for the answer's RelatesTo
  // The Probe asks for what a camera is: no Types, or NetworkVideoTransmitter or Device among
  // them (by local name: prefixes are the prober's).
  bool wants_camera = false;
  std::string error;  // why it is not a Probe
};
ProbeRead readProbe(std::string_view bytes);

struct DiscoveredCamera {
  std::string endpoint;  // urn:uuid:…, the same for the camera's life
  std::string xaddr;     // http://host:port/onvif/device_service
  std::string name;      // onvif://www.onvif.org/name/…
  std::string hardware;  // onvif://www.onvif.org/hardware/…
};
// The ProbeMatches message with one ProbeMatch (one camera per message, as cameras send it).
std::string probeMatchesMessage(const DiscoveredCamera& camera, std::string_view relates_to,
                                std::string_view message_id);

// A scope's value: RFC 3986 percent-encoding of everything but unreserved characters.
std::string scopeEncoded(std::string_view value);

}  // namespace ptz::driver
