#include "ptz_driver/heads/onvif/device_replies.hpp"

#include <algorithm>
#include <ctime>

namespace ptz::onvif {
namespace {

// An element that must be there: its text, or an Error naming it.
Result<std::string> need(const XmlNode& node, std::string_view field) {
  if (!node.valid()) return Error{std::string(field) + ": missing", std::nullopt};
  return node.text();
}

Result<long long> needInteger(const XmlNode& node, std::string_view field, long long min,
                              long long max) {
  const Result<std::string> text = need(node, field);
  if (!text) return text.fullError();
  return readInteger(*text, field, min, max);
}

// An optional XAddr: empty when the element is absent.
Result<std::string> optionalUrl(const XmlNode& node, std::string_view field) {
  if (!node.valid()) return std::string();
  return readUrl(node.text(), field, {"http://", "https://"});
}

}  // namespace

Result<std::string> readUrl(std::string_view text, std::string_view field,
                            std::initializer_list<std::string_view> schemes) {
  Result<std::string> url = readText(text, field, kMaxUrlChars);
  if (!url) return url;
  bool known = false;
  for (std::string_view scheme : schemes) {
    known = known || (text.size() > scheme.size() && text.substr(0, scheme.size()) == scheme);
  }
  if (!known || text.find(' ') != std::string_view::npos) {
    return Error{std::string(field) + " '" + std::string(text.substr(0, 64)) +
                     "': not a URL of the expected scheme",
                 std::nullopt};
  }
  return url;
}

Result<double> parseSystemDateAndTime(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetSystemDateAndTimeResponse", kDeviceNs);
  if (!r) return r.fullError();
  const XmlNode utc = r->response.find({"SystemDateAndTime", "UTCDateTime"});
  if (!utc.valid()) return Error{"SystemDateAndTime/UTCDateTime: missing", std::nullopt};
  struct Part {
    const char* name;
    XmlNode node;
    long long min, max;
  };
  const Part parts[] = {
      {"UTCDateTime/Date/Year", utc.find({"Date", "Year"}), 1970, 2200},
      {"UTCDateTime/Date/Month", utc.find({"Date", "Month"}), 1, 12},
      {"UTCDateTime/Date/Day", utc.find({"Date", "Day"}), 1, 31},
      {"UTCDateTime/Time/Hour", utc.find({"Time", "Hour"}), 0, 23},
      {"UTCDateTime/Time/Minute", utc.find({"Time", "Minute"}), 0, 59},
      {"UTCDateTime/Time/Second", utc.find({"Time", "Second"}), 0, 60},
  };
  long long v[6];
  for (int i = 0; i < 6; ++i) {
    const Result<long long> n =
        needInteger(parts[i].node, parts[i].name, parts[i].min, parts[i].max);
    if (!n) return n.fullError();
    v[i] = *n;
  }
  std::tm tm{};
  tm.tm_year = static_cast<int>(v[0] - 1900);
  tm.tm_mon = static_cast<int>(v[1] - 1);
  tm.tm_mday = static_cast<int>(v[2]);
  tm.tm_hour = static_cast<int>(v[3]);
  tm.tm_min = static_cast<int>(v[4]);
  tm.tm_sec = static_cast<int>(v[5]);
  const std::time_t t = timegm(&tm);
  // timegm normalises 31 February to March: such a date is refused, not moved.
  if (tm.tm_mday != v[2] || tm.tm_mon != v[1] - 1) {
    return Error{"UTCDateTime/Date: " + std::to_string(v[0]) + "-" + std::to_string(v[1]) + "-" +
                     std::to_string(v[2]) + " is not a date",
                 std::nullopt};
  }
  return static_cast<double>(t);
}

Result<ServiceAddresses> parseCapabilities(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetCapabilitiesResponse", kDeviceNs);
  if (!r) return r.fullError();
  const XmlNode caps = r->response.child("Capabilities");
  if (!caps.valid()) return Error{"Capabilities: missing", std::nullopt};
  ServiceAddresses a;
  struct Service {
    const char* element;
    const char* field;
    std::string* url;
  };
  for (const Service& s : {Service{"Device", "Capabilities/Device/XAddr", &a.device_url},
                           Service{"Media", "Capabilities/Media/XAddr", &a.media_url},
                           Service{"PTZ", "Capabilities/PTZ/XAddr", &a.ptz_url}}) {
    const Result<std::string> url = optionalUrl(caps.find({s.element, "XAddr"}), s.field);
    if (!url) return url.fullError();
    *s.url = *url;
  }
  if (a.media_url.empty() && a.ptz_url.empty()) {
    return Error{"Capabilities: neither Media nor PTZ has an XAddr", std::nullopt};
  }
  return a;
}

Result<ServiceAddresses> parseServices(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetServicesResponse", kDeviceNs);
  if (!r) return r.fullError();
  ServiceAddresses a;
  for (const XmlNode& service : r->response.children("Service")) {
    const std::string ns = service.child("Namespace").text();
    std::string* url = ns == kDeviceNs  ? &a.device_url
                       : ns == kMediaNs ? &a.media_url
                       : ns == kPtzNs   ? &a.ptz_url
                                        : nullptr;
    if (!url) continue;
    const Result<std::string> xaddr =
        readUrl(service.child("XAddr").text(), "Service " + ns + " XAddr", {"http://", "https://"});
    if (!xaddr) return xaddr.fullError();
    *url = *xaddr;
  }
  if (a.media_url.empty() && a.ptz_url.empty()) {
    return Error{"Services: neither the media nor the PTZ service is listed", std::nullopt};
  }
  return a;
}

Result<std::vector<MediaProfile>> parseProfiles(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetProfilesResponse", kMediaNs);
  if (!r) return r.fullError();
  const std::vector<XmlNode> nodes = r->response.children("Profiles");
  if (nodes.empty()) return Error{"Profiles: none", std::nullopt};
  if (nodes.size() > kMaxProfiles) {
    return Error{"Profiles: " + std::to_string(nodes.size()) + " (at most " +
                     std::to_string(kMaxProfiles) + ")",
                 std::nullopt};
  }
  std::vector<MediaProfile> profiles;
  for (const XmlNode& p : nodes) {
    MediaProfile m;
    const Result<std::string> token =
        readText(p.attribute("token").value_or(""), "Profiles@token", kMaxTokenChars);
    if (!token) return token.fullError();
    m.token = *token;
    const std::string where = "Profile '" + m.token + "' ";
    const Result<std::string> name =
        readText(p.child("Name").text(), where + "Name", kMaxNameChars, 0);
    if (!name) return name.fullError();
    m.name = *name;
    const XmlNode ptz = p.child("PTZConfiguration");
    if (ptz.valid()) {
      const Result<std::string> config = readText(ptz.attribute("token").value_or(""),
                                                  where + "PTZConfiguration@token", kMaxTokenChars);
      if (!config) return config.fullError();
      const Result<std::string> node = readText(
          ptz.child("NodeToken").text(), where + "PTZConfiguration/NodeToken", kMaxTokenChars);
      if (!node) return node.fullError();
      m.ptz_configuration_token = *config;
      m.ptz_node_token = *node;
    }
    const XmlNode resolution = p.find({"VideoEncoderConfiguration", "Resolution"});
    if (resolution.valid()) {
      const Result<long long> w =
          needInteger(resolution.child("Width"),
                      where + "VideoEncoderConfiguration/Resolution/Width", 1, 16384);
      if (!w) return w.fullError();
      const Result<long long> h =
          needInteger(resolution.child("Height"),
                      where + "VideoEncoderConfiguration/Resolution/Height", 1, 16384);
      if (!h) return h.fullError();
      m.video_width_px = static_cast<int>(*w);
      m.video_height_px = static_cast<int>(*h);
    }
    profiles.push_back(std::move(m));
  }
  return profiles;
}

Result<std::string> parseStreamUri(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetStreamUriResponse", kMediaNs);
  if (!r) return r.fullError();
  const XmlNode uri = r->response.find({"MediaUri", "Uri"});
  if (!uri.valid()) return Error{"MediaUri/Uri: missing", std::nullopt};
  return readUrl(uri.text(), "MediaUri/Uri", {"rtsp://", "rtsps://"});
}

namespace {

// A whitespace-separated list (xs:list), each item checked.
Result<std::vector<std::string>> readList(std::string_view text, const std::string& field,
                                          std::size_t max_chars) {
  std::vector<std::string> items;
  std::size_t at = 0;
  while (true) {
    at = text.find_first_not_of(" \t\r\n", at);
    if (at == std::string_view::npos) break;
    const std::size_t end = std::min(text.find_first_of(" \t\r\n", at), text.size());
    if (items.size() == kMaxListItems) {
      return Error{field + ": more than " + std::to_string(kMaxListItems) + " items", std::nullopt};
    }
    Result<std::string> item = readText(text.substr(at, end - at), field, max_chars);
    if (!item) return item.fullError();
    items.push_back(std::move(item.value()));
    at = end;
  }
  return items;
}

}  // namespace

Result<std::vector<ProbeMatch>> parseProbeMatches(std::string_view reply,
                                                  std::string_view message_id) {
  const Result<SoapReply> r = openReply(reply, "ProbeMatches", kDiscoveryNs);
  if (!r) return r.fullError();
  if (!message_id.empty()) {
    const std::string relates_to = r->doc.root().find({"Header", "RelatesTo"}).text();
    if (relates_to != message_id) {
      return Error{"Header/RelatesTo '" + relates_to.substr(0, 64) + "': not our Probe's " +
                       std::string(message_id),
                   std::nullopt};
    }
  }
  const std::vector<XmlNode> nodes = r->response.children("ProbeMatch");
  if (nodes.size() > kMaxListItems) {
    return Error{"ProbeMatch: " + std::to_string(nodes.size()) + " matches", std::nullopt};
  }
  std::vector<ProbeMatch> matches;
  for (const XmlNode& n : nodes) {
    ProbeMatch m;
    const Result<std::string> endpoint =
        readText(n.find({"EndpointReference", "Address"}).text(),
                 "ProbeMatch/EndpointReference/Address", kMaxNameChars);
    if (!endpoint) return endpoint.fullError();
    m.endpoint = *endpoint;
    const std::string where = "ProbeMatch '" + m.endpoint + "' ";
    Result<std::vector<std::string>> types =
        readList(n.child("Types").text(), where + "Types", kMaxNameChars);
    if (!types) return types.fullError();
    m.types = std::move(types.value());
    Result<std::vector<std::string>> scopes =
        readList(n.child("Scopes").text(), where + "Scopes", kMaxNameChars);
    if (!scopes) return scopes.fullError();
    m.scopes = std::move(scopes.value());
    Result<std::vector<std::string>> xaddrs =
        readList(n.child("XAddrs").text(), where + "XAddrs", kMaxUrlChars);
    if (!xaddrs) return xaddrs.fullError();
    for (const std::string& x : *xaddrs) {
      const Result<std::string> url = readUrl(x, where + "XAddrs", {"http://", "https://"});
      if (!url) return url.fullError();
    }
    if (xaddrs->empty()) return Error{where + "XAddrs: none", std::nullopt};
    m.xaddrs = std::move(xaddrs.value());
    matches.push_back(std::move(m));
  }
  return matches;
}

}  // namespace ptz::onvif
