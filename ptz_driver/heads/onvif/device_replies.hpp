// The device and media services' replies read into plain structs: the camera's clock (for the
// WS-Security token's time), the services' addresses, the media profiles, the stream URI. Every
// value is checked (ranges, lengths, no control characters); a missing or bad one is an Error
// naming the field and the value.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "ptz_driver/heads/onvif/soap.hpp"

namespace ptz::onvif {

// Longest token (tt:ReferenceToken, onvif.xsd: 64), name and URL read.
constexpr std::size_t kMaxTokenChars = 64;
constexpr std::size_t kMaxNameChars = 256;
constexpr std::size_t kMaxUrlChars = 2048;
constexpr std::size_t kMaxProfiles = 64;

// GetSystemDateAndTime: the camera's UTCDateTime as unix seconds (clock offset = this minus our
// clock at the reply's arrival).
Result<double> parseSystemDateAndTime(std::string_view reply);

// Where the services answer; empty when the camera has no such service.
struct ServiceAddresses {
  std::string device_url;
  std::string media_url;
  std::string ptz_url;
};
// GetCapabilities (tt:Device/Media/PTZ XAddr) or GetServices (tds:Service by namespace).
Result<ServiceAddresses> parseCapabilities(std::string_view reply);
Result<ServiceAddresses> parseServices(std::string_view reply);

struct MediaProfile {
  std::string token;
  std::string name;
  std::string ptz_configuration_token;  // empty: no PTZ in this profile
  std::string ptz_node_token;
  int video_width_px = 0;  // 0: no video encoder configuration
  int video_height_px = 0;
};
Result<std::vector<MediaProfile>> parseProfiles(std::string_view reply);

// GetStreamUri: an rtsp:// (or rtsps://) URL.
Result<std::string> parseStreamUri(std::string_view reply);

// WS-Discovery ProbeMatches (answering probeMessage(message_id), requests.hpp): each device's
// endpoint (urn:uuid:…), Types, Scopes (onvif://www.onvif.org/…) and XAddrs (device service
// URLs). A reply relating to another message is refused; empty message_id: not checked.
struct ProbeMatch {
  std::string endpoint;
  std::vector<std::string> types;
  std::vector<std::string> scopes;
  std::vector<std::string> xaddrs;
};
constexpr std::size_t kMaxListItems = 64;
Result<std::vector<ProbeMatch>> parseProbeMatches(std::string_view reply,
                                                  std::string_view message_id);

// Shared by the readers: an http(s) URL of at most kMaxUrlChars, no spaces or control characters.
Result<std::string> readUrl(std::string_view text, std::string_view field,
                            std::initializer_list<std::string_view> schemes);

}  // namespace ptz::onvif
