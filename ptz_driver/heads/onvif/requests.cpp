#include "ptz_driver/heads/onvif/requests.hpp"

#include <cstdio>

#include "ptz_driver/heads/onvif/soap.hpp"
#include "ptz_driver/heads/onvif/ws_security.hpp"
#include "ptz_driver/heads/onvif/xml.hpp"

namespace ptz::onvif {
namespace {

std::string action(std::string_view ns, std::string_view name) {
  return std::string(ns) + "/" + std::string(name);
}

// <prefix:name>escaped text</prefix:name>
std::string element(std::string_view qname, std::string_view text) {
  return "<" + std::string(qname) + ">" + xmlEscape(text) + "</" + std::string(qname) + ">";
}

std::string spaceAttribute(const std::string& space) {
  return space.empty() ? "" : " space=\"" + xmlEscape(space) + "\"";
}

// The tt:PanTilt and tt:Zoom children of a PTZVector or PTZSpeed named `qname`.
std::string vector(std::string_view qname, const PtzVector& v) {
  std::string s = "<" + std::string(qname) + ">";
  if (v.pan_tilt) {
    s += "<tt:PanTilt x=\"" + formatNumber(v.pan_tilt->x) + "\" y=\"" +
         formatNumber(v.pan_tilt->y) + "\"" + spaceAttribute(v.pan_tilt->space) + "/>";
  }
  if (v.zoom) {
    s += "<tt:Zoom x=\"" + formatNumber(v.zoom->x) + "\"" + spaceAttribute(v.zoom->space) + "/>";
  }
  return s + "</" + std::string(qname) + ">";
}

Request ptz(std::string_view name, const std::string& content) {
  return {action(kPtzNs, name),
          "<tptz:" + std::string(name) + ">" + content + "</tptz:" + std::string(name) + ">"};
}

std::string profile(std::string_view token) {
  return element("tptz:ProfileToken", token);
}

}  // namespace

Request getSystemDateAndTime() {
  return {action(kDeviceNs, "GetSystemDateAndTime"), "<tds:GetSystemDateAndTime/>"};
}

Request getCapabilities() {
  return {action(kDeviceNs, "GetCapabilities"),
          "<tds:GetCapabilities><tds:Category>All</tds:Category></tds:GetCapabilities>"};
}

Request getServices() {
  return {action(kDeviceNs, "GetServices"),
          "<tds:GetServices><tds:IncludeCapability>false</tds:IncludeCapability>"
          "</tds:GetServices>"};
}

Request getProfiles() {
  return {action(kMediaNs, "GetProfiles"), "<trt:GetProfiles/>"};
}

Request getStreamUri(std::string_view profile_token) {
  return {action(kMediaNs, "GetStreamUri"),
          "<trt:GetStreamUri><trt:StreamSetup><tt:Stream>RTP-Unicast</tt:Stream>"
          "<tt:Transport><tt:Protocol>RTSP</tt:Protocol></tt:Transport></trt:StreamSetup>" +
              element("trt:ProfileToken", profile_token) + "</trt:GetStreamUri>"};
}

Request getNodes() {
  return {action(kPtzNs, "GetNodes"), "<tptz:GetNodes/>"};
}

Request getConfigurationOptions(std::string_view configuration_token) {
  return ptz("GetConfigurationOptions", element("tptz:ConfigurationToken", configuration_token));
}

Request getStatus(std::string_view profile_token) {
  return ptz("GetStatus", profile(profile_token));
}

Request absoluteMove(std::string_view profile_token, const PtzVector& position,
                     const std::optional<PtzVector>& speed) {
  return ptz("AbsoluteMove", profile(profile_token) + vector("tptz:Position", position) +
                                 (speed ? vector("tptz:Speed", *speed) : ""));
}

Request relativeMove(std::string_view profile_token, const PtzVector& translation,
                     const std::optional<PtzVector>& speed) {
  return ptz("RelativeMove", profile(profile_token) + vector("tptz:Translation", translation) +
                                 (speed ? vector("tptz:Speed", *speed) : ""));
}

Request continuousMove(std::string_view profile_token, const PtzVector& velocity,
                       std::optional<double> timeout_s) {
  return ptz("ContinuousMove",
             profile(profile_token) + vector("tptz:Velocity", velocity) +
                 (timeout_s ? element("tptz:Timeout", formatDuration(*timeout_s)) : ""));
}

Request stop(std::string_view profile_token, bool pan_tilt, bool zoom) {
  return ptz("Stop", profile(profile_token) + element("tptz:PanTilt", pan_tilt ? "true" : "false") +
                         element("tptz:Zoom", zoom ? "true" : "false"));
}

Request getPresets(std::string_view profile_token) {
  return ptz("GetPresets", profile(profile_token));
}

Request gotoPreset(std::string_view profile_token, std::string_view preset_token,
                   const std::optional<PtzVector>& speed) {
  return ptz("GotoPreset", profile(profile_token) + element("tptz:PresetToken", preset_token) +
                               (speed ? vector("tptz:Speed", *speed) : ""));
}

Request setPreset(std::string_view profile_token, std::string_view preset_name,
                  std::string_view preset_token) {
  return ptz("SetPreset",
             profile(profile_token) +
                 (preset_name.empty() ? "" : element("tptz:PresetName", preset_name)) +
                 (preset_token.empty() ? "" : element("tptz:PresetToken", preset_token)));
}

std::string probeMessage(std::string_view message_id) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?><s:Envelope xmlns:s=\"" + std::string(kSoapNs) +
         "\" xmlns:a=\"" + std::string(kAddressingNs) + "\" xmlns:d=\"" +
         std::string(kDiscoveryNs) +
         "\" xmlns:dn=\"http://www.onvif.org/ver10/network/wsdl\"><s:Header>"
         "<a:Action s:mustUnderstand=\"1\">http://schemas.xmlsoap.org/ws/2005/04/discovery/Probe"
         "</a:Action>" +
         element("a:MessageID", message_id) +
         "<a:ReplyTo><a:Address>http://schemas.xmlsoap.org/ws/2004/08/addressing/role/anonymous"
         "</a:Address></a:ReplyTo><a:To s:mustUnderstand=\"1\">"
         "urn:schemas-xmlsoap-org:ws:2005:04:discovery</a:To></s:Header><s:Body><d:Probe>"
         "<d:Types>dn:NetworkVideoTransmitter</d:Types></d:Probe></s:Body></s:Envelope>";
}

}  // namespace ptz::onvif
