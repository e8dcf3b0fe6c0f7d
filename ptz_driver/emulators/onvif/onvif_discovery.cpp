#include "ptz_driver/emulators/onvif/onvif_discovery.hpp"

#include <cctype>
#include <cstdio>
#include <sstream>

#include "ptz_driver/heads/onvif/ws_security.hpp"
#include "ptz_driver/heads/onvif/xml.hpp"

namespace ptz::driver {
namespace {

constexpr std::string_view kSoapNs = "http://www.w3.org/2003/05/soap-envelope";
constexpr std::string_view kAddressingNs = "http://schemas.xmlsoap.org/ws/2004/08/addressing";
constexpr std::string_view kDiscoveryNs = "http://schemas.xmlsoap.org/ws/2005/04/discovery";
constexpr std::string_view kProbeAction = "http://schemas.xmlsoap.org/ws/2005/04/discovery/Probe";

ProbeRead refused(std::string why) {
  ProbeRead r;
  r.error = std::move(why);
  return r;
}

bool printable(const std::string& s) {
  for (char c : s) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
  }
  return true;
}

}  // namespace

ProbeRead readProbe(std::string_view bytes) {
  const onvif::XmlDocument doc = onvif::XmlDocument::parse(bytes);
  if (!doc.ok()) return refused("not XML: " + doc.error());
  const onvif::XmlNode env = doc.root();
  if (env.localName() != "Envelope" || env.namespaceUri() != kSoapNs) {
    return refused("not a SOAP 1.2 Envelope");
  }
  const onvif::XmlNode header = env.child("Header");
  const onvif::XmlNode action = header.child("Action");
  if (!action.valid() || action.namespaceUri() != kAddressingNs || action.text() != kProbeAction) {
    return refused("Header/Action is not WS-Discovery's Probe");
  }
  const onvif::XmlNode id = header.child("MessageID");
  ProbeRead r;
  r.message_id = id.text();
  if (!id.valid() || id.namespaceUri() != kAddressingNs || r.message_id.empty() ||
      r.message_id.size() > kMaxProbeMessageIdChars || !printable(r.message_id)) {
    return refused("Header/MessageID missing, longer than " +
                   std::to_string(kMaxProbeMessageIdChars) + " or not printable");
  }
  const onvif::XmlNode probe = env.find({"Body", "Probe"});
  if (!probe.valid() || probe.namespaceUri() != kDiscoveryNs) return refused("no Body/Probe");
  std::istringstream types(probe.child("Types").text());
  r.wants_camera = true;
  bool any = false;
  for (std::string t; types >> t;) {
    if (!any) r.wants_camera = false;
    any = true;
    const std::string local = t.substr(t.find(':') == std::string::npos ? 0 : t.find(':') + 1);
    if (local == "NetworkVideoTransmitter" || local == "Device") r.wants_camera = true;
  }
  r.ok = true;
  return r;
}

std::string scopeEncoded(std::string_view value) {
  std::string out;
  for (char c : value) {
    const unsigned char u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '-' || c == '.' || c == '_' || c == '~') {
      out += c;
    } else {
      char hex[4];
      std::snprintf(hex, sizeof hex, "%%%02X", u);
      out += hex;
    }
  }
  return out;
}

std::string probeMatchesMessage(const DiscoveredCamera& camera, std::string_view relates_to,
                                std::string_view message_id) {
  using onvif::xmlEscape;
  const std::string scopes =
      "onvif://www.onvif.org/type/video_encoder onvif://www.onvif.org/type/ptz "
      "onvif://www.onvif.org/Profile/Streaming onvif://www.onvif.org/name/" +
      scopeEncoded(camera.name) + " onvif://www.onvif.org/hardware/" +
      scopeEncoded(camera.hardware) + " onvif://www.onvif.org/location/ptz-sim";
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?><s:Envelope xmlns:s=\"" + std::string(kSoapNs) +
         "\" xmlns:a=\"" + std::string(kAddressingNs) + "\" xmlns:d=\"" +
         std::string(kDiscoveryNs) +
         "\" xmlns:dn=\"http://www.onvif.org/ver10/network/wsdl\" "
         "xmlns:tds=\"http://www.onvif.org/ver10/device/wsdl\"><s:Header><a:MessageID>" +
         xmlEscape(message_id) + "</a:MessageID><a:RelatesTo>" + xmlEscape(relates_to) +
         "</a:RelatesTo><a:To>http://schemas.xmlsoap.org/ws/2004/08/addressing/role/anonymous"
         "</a:To><a:Action>http://schemas.xmlsoap.org/ws/2005/04/discovery/ProbeMatches"
         "</a:Action></s:Header><s:Body><d:ProbeMatches><d:ProbeMatch><a:EndpointReference>"
         "<a:Address>" +
         xmlEscape(camera.endpoint) +
         "</a:Address></a:EndpointReference><d:Types>dn:NetworkVideoTransmitter tds:Device"
         "</d:Types><d:Scopes>" +
         xmlEscape(scopes) + "</d:Scopes><d:XAddrs>" + xmlEscape(camera.xaddr) +
         "</d:XAddrs><d:MetadataVersion>1</d:MetadataVersion></d:ProbeMatch></d:ProbeMatches>"
         "</s:Body></s:Envelope>";
}

}  // namespace ptz::driver
