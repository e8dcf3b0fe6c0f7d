#include "ptz_driver/heads/onvif/discovery/discover_command.hpp"

#include <string>

#include "ptz_driver/heads/onvif/discovery/camera_listing.hpp"
#include "ptz_driver/heads/onvif/discovery/ws_discovery.hpp"
#include "ptz_driver/heads/onvif/head/onvif_head.hpp"  // onvifHeadPassword

namespace ptz::driver {

void declareDiscoverParams(Params& p) {
  p.add("discover", false,
        "find the ONVIF cameras (WS-Discovery), print them (and, with onvif_user and a password, "
        "their RTSP streams) and exit");
  p.add("discover_timeout_ms", 2000, "ms", "discover: how long answers are collected",
        Range::between(10, 60000));
  p.add("discover_ttl", 1, "", "discover: multicast TTL of the Probe (1: this network only)",
        Range::between(1, 255));
  p.add("discover_interface", "",
        "discover: IPv4 address of the interface the Probe leaves by (empty: the routing table's)");
}

std::optional<int> runDiscoverIfAsked(int argc, char** argv, Params& p) {
  try {
    if (!p.parse(argc, argv)) return 0;  // --help
    if (!p.getBool("discover")) return std::nullopt;
    return runDiscover(p, stdout, stderr);
  } catch (const ConfigError& e) {
    std::fprintf(stderr, "%s: %s\n", p.program().c_str(), e.what());
    return 2;
  }
}

int runDiscover(const Params& p, std::FILE* out, std::FILE* err) {
  const char* me = p.program().c_str();
  onvif::DiscoveryOptions options;
  options.timeout_ms = p.getInt("discover_timeout_ms");
  options.ttl = p.getInt("discover_ttl");
  options.interface_address = p.getString("discover_interface");
  const std::string user = p.getString("onvif_user");
  const std::string password = onvifHeadPassword(p.getPath("onvif_password_file"));
  const auto found = onvif::discover(options);
  if (!found) {
    std::fprintf(err, "%s: %s\n", me, found.error().c_str());
    return 1;
  }
  const onvif::DiscoveryCounters& c = found->counters;
  if (c.oversize + c.wrong_relates_to + c.malformed + c.beyond_limits > 0) {
    std::fprintf(err,
                 "%s: WS-Discovery: answers dropped: %lld too large, %lld for another Probe, "
                 "%lld malformed, %lld beyond the limits\n",
                 me, static_cast<long long>(c.oversize), static_cast<long long>(c.wrong_relates_to),
                 static_cast<long long>(c.malformed), static_cast<long long>(c.beyond_limits));
    for (const std::string& why : found->problems) std::fprintf(err, "  %s\n", why.c_str());
  }
  if (found->devices.empty()) {
    std::fprintf(err,
                 "%s: WS-Discovery: no ONVIF camera answered within %d ms (cameras on another "
                 "network or with discovery off? discover_interface picks the interface)\n",
                 me, options.timeout_ms);
    return 1;
  }
  if (password.empty()) {
    std::fprintf(err,
                 "%s: no password (onvif_password_file or PTZ_ONVIF_PASSWORD): streams not "
                 "listed\n",
                 me);
  }
  int code = 0;
  for (const onvif::ProbeMatch& d : found->devices) {
    std::string xaddrs;
    for (const std::string& x : d.xaddrs) xaddrs += (xaddrs.empty() ? "" : " ") + x;
    std::fprintf(out, "camera %s xaddrs %s name '%s' hardware '%s'\n", d.endpoint.c_str(),
                 xaddrs.c_str(), onvif::scopeValue(d.scopes, "name").c_str(),
                 onvif::scopeValue(d.scopes, "hardware").c_str());
    if (password.empty()) continue;
    const onvif::CameraListing l =
        onvif::listStreams(d.xaddrs.front(), user, password, options.timeout_ms);
    for (const onvif::StreamListing& s : l.streams) {
      std::fprintf(out, "  profile %s name '%s' %dx%d%s stream %s\n", s.profile_token.c_str(),
                   s.profile_name.c_str(), s.width_px, s.height_px, s.ptz ? " ptz" : "",
                   s.uri.c_str());
      std::fprintf(out,
                   "    ptz-camera --left-source %s  # or --right-source: this camera's side\n",
                   s.uri.c_str());
    }
    if (!l.error.empty()) {
      std::fprintf(err, "%s: camera %s (%s): %s\n", me, d.endpoint.c_str(),
                   d.xaddrs.front().c_str(), l.error.c_str());
      code = 4;
    }
  }
  return code;
}

}  // namespace ptz::driver
