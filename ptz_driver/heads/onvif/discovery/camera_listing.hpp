// What ptz-driver --discover tells of one camera it found: its media profiles and their RTSP
// stream URIs (GetSystemDateAndTime for the camera's clock, GetCapabilities or GetServices,
// GetProfiles, GetStreamUri per profile), signed with a WS-UsernameToken in the camera's time and
// HTTP digest where the camera asks for it. Blocking (libcurl); no LCM.
#pragma once

#include <string>
#include <vector>

namespace ptz::onvif {

struct StreamListing {
  std::string profile_token;
  std::string profile_name;
  int width_px = 0;  // 0: no video encoder configuration
  int height_px = 0;
  bool ptz = false;  // the profile has a PTZ configuration
  std::string uri;   // rtsp://…
};

struct CameraListing {
  std::vector<StreamListing> streams;
  std::string error;  // the operation that failed and why; empty: all listed
};

// device_url: an XAddr (http://host:port/onvif/device_service). The password is used, never shown.
CameraListing listStreams(const std::string& device_url, const std::string& user,
                          const std::string& password, int timeout_ms);

}  // namespace ptz::onvif
