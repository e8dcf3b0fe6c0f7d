// The bodies of the ONVIF requests the client sends, element for element as devicemgmt.wsdl,
// media.wsdl, ptz.wsdl and onvif.xsd define them (prefixes tds, trt, tptz, tt as envelope()
// declares them), each with its SOAP action. Every text is escaped; numbers are printed in the C
// locale with the digits to read back the same double. A non-finite number is the caller's bug:
// std::invalid_argument (the driver refuses non-finite setpoints long before).
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace ptz::onvif {

struct Request {
  std::string action;  // http://www.onvif.org/ver20/ptz/wsdl/AbsoluteMove
  std::string body;    // the Body's content
};

// tt:Vector2D: x is pan, y tilt, in the units of `space` (empty: the attribute is left out and
// the camera uses its configuration's default space; generic position space: -1..1).
struct Vector2D {
  double x = 0.0;
  double y = 0.0;
  std::string space;
};
// tt:Vector1D: zoom.
struct Vector1D {
  double x = 0.0;
  std::string space;
};
// tt:PTZVector and tt:PTZSpeed (same shape): either part may be left out.
struct PtzVector {
  std::optional<Vector2D> pan_tilt;
  std::optional<Vector1D> zoom;
};

// Device service (tds).
Request getSystemDateAndTime();
Request getCapabilities();  // Category All
Request getServices();      // IncludeCapability false
// Media service (trt).
Request getProfiles();
Request getStreamUri(std::string_view profile_token);  // RTP-Unicast over RTSP
// PTZ service (tptz).
Request getNodes();
Request getConfigurationOptions(std::string_view configuration_token);
Request getStatus(std::string_view profile_token);
Request absoluteMove(std::string_view profile_token, const PtzVector& position,
                     const std::optional<PtzVector>& speed = std::nullopt);
Request relativeMove(std::string_view profile_token, const PtzVector& translation,
                     const std::optional<PtzVector>& speed = std::nullopt);
// Velocity; the camera stops by itself after timeout_s when given.
Request continuousMove(std::string_view profile_token, const PtzVector& velocity,
                       std::optional<double> timeout_s = std::nullopt);
Request stop(std::string_view profile_token, bool pan_tilt, bool zoom);
Request getPresets(std::string_view profile_token);
Request gotoPreset(std::string_view profile_token, std::string_view preset_token,
                   const std::optional<PtzVector>& speed = std::nullopt);
// Either may be empty: a new preset (the camera picks the token) or one overwritten.
Request setPreset(std::string_view profile_token, std::string_view preset_name,
                  std::string_view preset_token = "");

// WS-Discovery (the 2005/04 version ONVIF uses): the whole Probe message for
// NetworkVideoTransmitters, sent by UDP to 239.255.255.250:3702; cameras answer ProbeMatches
// (device_replies.hpp) relating to `message_id`.
std::string probeMessage(std::string_view message_id);

}  // namespace ptz::onvif
