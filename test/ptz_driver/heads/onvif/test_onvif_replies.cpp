// ptz_onvif's reply parsers on recorded-style camera replies (test/fixtures/onvif/, from the npm
// package onvif, MIT) with known answers, and on hostile replies: truncated, DTDs, too large, too
// deep, numbers that are no numbers, missing fields, wrong namespaces, SOAP faults.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "ptz_driver/heads/onvif/device_replies.hpp"
#include "ptz_driver/heads/onvif/ptz_replies.hpp"
#include "ptz_driver/heads/onvif/soap.hpp"

namespace ptz::onvif {
namespace {

std::string fixture(const std::string& name) {
  std::ifstream in(std::string(PTZ_SOURCE_DIR) + "/test/fixtures/onvif/" + name, std::ios::binary);
  EXPECT_TRUE(in) << name;
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// `text` with the first `from` replaced by `to` (the test fails when there is none).
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

const std::string kServices = "http://192.168.68.111/onvif/services";

TEST(OnvifReplies, SystemDateAndTime) {
  const Result<double> t = parseSystemDateAndTime(fixture("GetSystemDateAndTime.xml"));
  ASSERT_TRUE(t) << t.error();
  EXPECT_EQ(*t, 1419448477.0);  // 2014-12-24T19:14:37Z
}

TEST(OnvifReplies, CapabilitiesAndServices) {
  const Result<ServiceAddresses> c = parseCapabilities(fixture("GetCapabilities.xml"));
  ASSERT_TRUE(c) << c.error();
  EXPECT_EQ(c->device_url, kServices);
  EXPECT_EQ(c->media_url, kServices);
  EXPECT_EQ(c->ptz_url, kServices);
  const Result<ServiceAddresses> s = parseServices(fixture("GetServices.xml"));
  ASSERT_TRUE(s) << s.error();
  EXPECT_EQ(s->device_url, kServices);
  EXPECT_EQ(s->media_url, kServices);
  EXPECT_EQ(s->ptz_url, kServices);
  // Without a PTZ service the address is empty, not an error.
  const std::string no_ptz =
      replaced(fixture("GetServices.xml"), "<tds:Namespace>http://www.onvif.org/ver20/ptz/wsdl",
               "<tds:Namespace>http://www.onvif.org/ver10/other/wsdl");
  const Result<ServiceAddresses> n = parseServices(no_ptz);
  ASSERT_TRUE(n) << n.error();
  EXPECT_EQ(n->ptz_url, "");
}

TEST(OnvifReplies, ProfilesAndStreamUri) {
  const Result<std::vector<MediaProfile>> p = parseProfiles(fixture("GetProfiles.xml"));
  ASSERT_TRUE(p) << p.error();
  ASSERT_EQ(p->size(), 1u);
  const MediaProfile& m = p->front();
  EXPECT_EQ(m.token, "main");
  EXPECT_EQ(m.name, "main");
  EXPECT_EQ(m.ptz_configuration_token, "default");
  EXPECT_EQ(m.ptz_node_token, "default");
  EXPECT_EQ(m.video_width_px, 1920);
  EXPECT_EQ(m.video_height_px, 1080);
  const Result<std::string> uri = parseStreamUri(fixture("GetStreamUri.xml"));
  ASSERT_TRUE(uri) << uri.error();
  EXPECT_EQ(*uri, "rtsp://192.168.68.111/h264main");
}

void expectGenericSpaces(const PtzSpaces& s) {
  ASSERT_TRUE(s.absolute_pan_tilt);
  EXPECT_EQ(s.absolute_pan_tilt->uri,
            "http://www.onvif.org/ver10/tptz/PanTiltSpaces/PositionGenericSpace");
  EXPECT_EQ(s.absolute_pan_tilt->x.min, 0.0);
  EXPECT_EQ(s.absolute_pan_tilt->x.max, 1.0);
  EXPECT_EQ(s.absolute_pan_tilt->y.min, 0.0);
  EXPECT_EQ(s.absolute_pan_tilt->y.max, 1.0);
  ASSERT_TRUE(s.absolute_zoom);
  EXPECT_EQ(s.absolute_zoom->x.max, 1.0);
  ASSERT_TRUE(s.continuous_pan_tilt_velocity);
  EXPECT_EQ(s.continuous_pan_tilt_velocity->x.min, -1.0);
  EXPECT_EQ(s.continuous_pan_tilt_velocity->y.max, 1.0);
  ASSERT_TRUE(s.continuous_zoom_velocity);
  EXPECT_EQ(s.continuous_zoom_velocity->x.min, -1.0);
  ASSERT_TRUE(s.relative_pan_tilt);
  ASSERT_TRUE(s.pan_tilt_speed);
  EXPECT_EQ(s.pan_tilt_speed->x.max, 1.0);
  ASSERT_TRUE(s.zoom_speed);
}

TEST(OnvifReplies, NodesAndConfigurationOptions) {
  const Result<std::vector<PtzNode>> n = parseNodes(fixture("GetNodes.xml"));
  ASSERT_TRUE(n) << n.error();
  ASSERT_EQ(n->size(), 1u);
  EXPECT_EQ(n->front().token, "default");
  EXPECT_EQ(n->front().name, "default");
  EXPECT_EQ(n->front().max_presets, 360);
  EXPECT_TRUE(n->front().home_supported);
  expectGenericSpaces(n->front().spaces);
  const Result<PtzConfigurationOptions> o =
      parseConfigurationOptions(fixture("GetConfigurationOptions.xml"));
  ASSERT_TRUE(o) << o.error();
  expectGenericSpaces(o->spaces);
  ASSERT_TRUE(o->timeout_s);
  EXPECT_EQ(o->timeout_s->min, 0.0);
  EXPECT_EQ(o->timeout_s->max, 10.0);
}

TEST(OnvifReplies, Status) {
  const Result<PtzStatus> s = parseStatus(fixture("GetStatus.xml"));
  ASSERT_TRUE(s) << s.error();
  EXPECT_EQ(s->pan.value_or(9), -0.864665985);
  EXPECT_EQ(s->tilt.value_or(9), 0.267444015);
  EXPECT_EQ(s->zoom.value_or(9), 0.211861998);
  EXPECT_EQ(s->pan_tilt_move, MoveState::kIdle);
  EXPECT_EQ(s->zoom_move, MoveState::kIdle);
  EXPECT_EQ(s->camera_utc_s.value_or(0), 1419883291.0);  // 2014-12-29T20:01:31Z
  const Result<PtzStatus> moving = parseStatus(
      replaced(fixture("GetStatus.xml"), "<tt:Zoom>IDLE</tt:Zoom>", "<tt:Zoom>MOVING</tt:Zoom>"));
  ASSERT_TRUE(moving) << moving.error();
  EXPECT_EQ(moving->zoom_move, MoveState::kMoving);
  EXPECT_EQ(moving->pan_tilt_move, MoveState::kIdle);
}

TEST(OnvifReplies, Presets) {
  const Result<std::vector<Preset>> p = parsePresets(fixture("GetPresets.xml"));
  ASSERT_TRUE(p) << p.error();
  ASSERT_EQ(p->size(), 45u);
  EXPECT_EQ(p->front().token, "P001");
  EXPECT_EQ(p->front().name, "P001");
  EXPECT_FALSE(p->front().pan);
  EXPECT_EQ(p->back().token, "Home");
  const Result<std::vector<Preset>> w = parsePresets(fixture("GetPresetsWithPositions.xml"));
  ASSERT_TRUE(w) << w.error();
  ASSERT_EQ(w->size(), 2u);
  EXPECT_EQ(w->at(0).token, "1");
  EXPECT_EQ(w->at(0).name, "Door & gate");
  EXPECT_EQ(w->at(0).pan.value_or(9), -0.5);
  EXPECT_EQ(w->at(0).tilt.value_or(9), 0.25);
  EXPECT_EQ(w->at(0).zoom.value_or(9), 0.125);
  EXPECT_FALSE(w->at(1).pan);
  const Result<std::string> set = parseSetPreset(fixture("SetPreset.xml"));
  ASSERT_TRUE(set) << set.error();
  EXPECT_EQ(*set, "20");
  const Result<bool> moved =
      parseEmptyPtzReply(fixture("AbsoluteMove.xml"), "AbsoluteMoveResponse");
  EXPECT_TRUE(moved) << moved.error();
  EXPECT_FALSE(parseEmptyPtzReply(fixture("AbsoluteMove.xml"), "StopResponse"));
}

// Every parser, for the replies every parser must refuse.
const std::vector<std::pair<const char*, std::function<std::string(const std::string&)>>> kParsers =
    {
        {"time", [](auto& b) { return parseSystemDateAndTime(b).error(); }},
        {"capabilities", [](auto& b) { return parseCapabilities(b).error(); }},
        {"services", [](auto& b) { return parseServices(b).error(); }},
        {"profiles", [](auto& b) { return parseProfiles(b).error(); }},
        {"uri", [](auto& b) { return parseStreamUri(b).error(); }},
        {"nodes", [](auto& b) { return parseNodes(b).error(); }},
        {"options", [](auto& b) { return parseConfigurationOptions(b).error(); }},
        {"status", [](auto& b) { return parseStatus(b).error(); }},
        {"presets", [](auto& b) { return parsePresets(b).error(); }},
        {"set preset", [](auto& b) { return parseSetPreset(b).error(); }},
        {"stop", [](auto& b) { return parseEmptyPtzReply(b, "StopResponse").error(); }},
};

TEST(OnvifRepliesHostile, NotAuthorizedFaultIsAClearError) {
  const std::string fault = fixture("FaultNotAuthorized.xml");
  for (const auto& [name, parse] : kParsers) {
    const std::string error = parse(fault);
    EXPECT_TRUE(contains(error, "SOAP fault env:Sender / ter:NotAuthorized: Sender not Authorized"))
        << name << ": " << error;
  }
  const Result<PtzStatus> s = parseStatus(fault);
  ASSERT_TRUE(s.fault());
  EXPECT_EQ(s.fault()->code, "env:Sender");
  EXPECT_EQ(s.fault()->subcode, "ter:NotAuthorized");
  EXPECT_EQ(s.fault()->reason, "Sender not Authorized");
}

TEST(OnvifRepliesHostile, BrokenAndOversizedXml) {
  const std::string status = fixture("GetStatus.xml");
  std::string deep = "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"><s:Body>";
  for (int i = 0; i < 100; ++i) deep += "<a>";
  for (int i = 0; i < 100; ++i) deep += "</a>";
  deep += "</s:Body></s:Envelope>";
  const std::string laughs =
      "<?xml version=\"1.0\"?><!DOCTYPE s:Envelope [<!ENTITY a \"aaaaaaaaaa\">"
      "<!ENTITY b \"&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;\"><!ENTITY c "
      "\"&b;&b;&b;&b;&b;&b;&b;&b;&b;\">]>" +
      replaced(status, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>", "");
  const std::string huge = replaced(status, "<SOAP-ENV:Body>",
                                    "<!--" + std::string(1 << 20, 'x') + "--><SOAP-ENV:Body>");
  const struct {
    const char* name;
    std::string bytes;
    const char* why;
  } cases[] = {
      {"empty", "", "not well-formed"},
      {"npm Error.xml", fixture("Error.xml"), "not well-formed"},
      {"deep", deep, "deeper"},
      {"1 MB", huge, "over the limit"},
      {"laughs", replaced(laughs, "<tt:PanTilt>IDLE", "<tt:PanTilt>&c;IDLE"), "entity"},
      {"DTD",
       "<!DOCTYPE x [<!ENTITY a \"b\">]>" +
           replaced(status, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>", ""),
       "DTD"},
      {"SOAP 1.1",
       replaced(status, "http://www.w3.org/2003/05/soap-envelope",
                "http://schemas.xmlsoap.org/soap/envelope/"),
       "not a SOAP 1.2 Envelope"},
      {"undeclared prefix", "<s:Envelope><s:Body/></s:Envelope>", "not a SOAP 1.2 Envelope"},
      {"no body", "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"/>", "no SOAP"},
      {"empty body",
       "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"><s:Body/></s:Envelope>",
       "Body is empty"},
  };
  for (const auto& c : cases) {
    for (const auto& [name, parse] : kParsers) {
      const std::string error = parse(c.bytes);
      EXPECT_TRUE(contains(error, c.why)) << c.name << " / " << name << ": " << error;
    }
  }
  // Every cut of a reply is refused with a reason.
  const std::size_t end = status.rfind("</");
  for (std::size_t n = 0; n < end; n += 7) {
    EXPECT_FALSE(parseStatus(status.substr(0, n)).error().empty()) << n;
  }
}

TEST(OnvifRepliesHostile, WrongResponseOrNamespace) {
  const std::string status = fixture("GetStatus.xml");
  EXPECT_TRUE(contains(parseNodes(status).error(), "expected GetNodesResponse"));
  const std::string error =
      parseStatus(replaced(status, "xmlns:tptz=\"http://www.onvif.org/ver20/ptz/wsdl\"",
                           "xmlns:tptz=\"http://www.onvif.org/ver10/ptz/wsdl\""))
          .error();
  EXPECT_TRUE(contains(error, "expected GetStatusResponse in http://www.onvif.org/ver20/ptz/wsdl"))
      << error;
}

TEST(OnvifRepliesHostile, NumbersThatAreNoNumbers) {
  const std::string status = fixture("GetStatus.xml");
  for (const char* bad :
       {"NaN", "INF", "-INF", "inf", "1e999", "", "0x10", " 1", "1.0.0", "2e6", "+-1", "1,5"}) {
    const std::string error =
        parseStatus(replaced(status, "x=\"-0.864665985\"", std::string("x=\"") + bad + "\""))
            .error();
    EXPECT_TRUE(contains(error, std::string("PTZStatus/Position/PanTilt@x '") + bad + "'"))
        << bad << ": " << error;
  }
  const std::string nodes = fixture("GetNodes.xml");
  const std::string range_error =
      parseNodes(replaced(nodes, "<tt:Max>1</tt:Max>", "<tt:Max>-1</tt:Max>")).error();
  EXPECT_TRUE(contains(range_error, "AbsolutePanTiltPositionSpace/XRange: Min 0 above Max -1"))
      << range_error;
  EXPECT_TRUE(contains(
      parseNodes(replaced(nodes, "<tt:MaximumNumberOfPresets>360", "<tt:MaximumNumberOfPresets>-3"))
          .error(),
      "MaximumNumberOfPresets '-3'"));
  EXPECT_TRUE(contains(
      parseNodes(replaced(nodes, "<tt:HomeSupported>true", "<tt:HomeSupported>yes")).error(),
      "HomeSupported 'yes': not an xs:boolean"));
  const std::string date = fixture("GetSystemDateAndTime.xml");
  EXPECT_TRUE(
      contains(parseSystemDateAndTime(replaced(date, "<tt:Month>12", "<tt:Month>13")).error(),
               "UTCDateTime/Date/Month '13': not in 1..12"));
  EXPECT_TRUE(
      contains(parseSystemDateAndTime(replaced(replaced(date, "<tt:Month>12", "<tt:Month>2"),
                                               "<tt:Day>24", "<tt:Day>30"))
                   .error(),
               "2014-2-30 is not a date"));
  EXPECT_TRUE(contains(parseConfigurationOptions(replaced(fixture("GetConfigurationOptions.xml"),
                                                          "<tt:Max>PT10S", "<tt:Max>P1Y"))
                           .error(),
                       "PTZTimeout/Max 'P1Y'"));
}

TEST(OnvifRepliesHostile, MissingFieldsAreNamed) {
  const struct {
    std::string error;
    const char* want;
  } cases[] = {
      {parseNodes(replaced(fixture("GetNodes.xml"),
                           "<tt:MaximumNumberOfPresets>360</tt:MaximumNumberOfPresets>", ""))
           .error(),
       "PTZNode 'default' MaximumNumberOfPresets: missing"},
      {parseSystemDateAndTime(
           replaced(fixture("GetSystemDateAndTime.xml"), "<tt:Year>2014</tt:Year>", ""))
           .error(),
       "UTCDateTime/Date/Year: missing"},
      {parseProfiles(replaced(fixture("GetProfiles.xml"), "fixed=\"true\" token=\"main\"", ""))
           .error(),
       "Profiles@token '': missing or empty"},
      {parseProfiles(replaced(fixture("GetProfiles.xml"), "<tt:Width>1920</tt:Width>", "")).error(),
       "Profile 'main' VideoEncoderConfiguration/Resolution/Width: missing"},
      {parseStreamUri(replaced(fixture("GetStreamUri.xml"),
                               "<tt:Uri>rtsp://192.168.68.111/h264main</tt:Uri>", ""))
           .error(),
       "MediaUri/Uri: missing"},
      {parseStreamUri(replaced(fixture("GetStreamUri.xml"), "rtsp://192", "file:///192")).error(),
       "MediaUri/Uri 'file:///192.168.68.111/h264main': not a URL"},
      {parseStatus(replaced(fixture("GetStatus.xml"), "y=\"0.267444015\"", "")).error(),
       "PTZStatus/Position/PanTilt@y: missing"},
      {parseStatus(replaced(fixture("GetStatus.xml"), "<tt:PanTilt>IDLE", "<tt:PanTilt>STOPPED"))
           .error(),
       "MoveStatus/PanTilt 'STOPPED'"},
      {parseStatus(replaced(fixture("GetStatus.xml"), "2014-12-29T20:01:31Z", "yesterday")).error(),
       "PTZStatus/UtcTime 'yesterday'"},
      {parsePresets(replaced(fixture("GetPresets.xml"), "token=\"P001\"",
                             "token=\"" + std::string(65, 'p') + "\""))
           .error(),
       "Preset@token 'ppp"},
      {parsePresets(replaced(fixture("GetPresets.xml"), "<tt:Name>P001", "<tt:Name>P&#9;01"))
           .error(),
       "Preset 'P001' Name 'P?01': holds a control character"},
      {parseCapabilities(replaced(fixture("GetCapabilities.xml"),
                                  "<tt:XAddr>http://192.168.68.111/onvif/services</tt:XAddr>\n     "
                                  "               <tt:StreamingCapabilities>",
                                  "<tt:XAddr>http://a b</tt:XAddr><tt:StreamingCapabilities>"))
           .error(),
       "Capabilities/Media/XAddr 'http://a b': not a URL"},
      {parseSetPreset(
           replaced(fixture("SetPreset.xml"), "<tptz:PresetToken>20</tptz:PresetToken>", ""))
           .error(),
       "SetPresetResponse/PresetToken: missing"},
  };
  for (const auto& c : cases)
    EXPECT_TRUE(contains(c.error, c.want)) << c.want << "\n  got: " << c.error;
}

TEST(OnvifReplies, ProbeMatches) {
  const std::string id = "urn:uuid:01234567-dead-beef-baad-abcdeffedcba";
  const std::string reply =
      replaced(fixture("ProbeMatches.xml"), "SERVICE_URI",
               "http://192.168.68.111/onvif/device_service  http://[fe80::1]/onvif/device_service");
  const Result<std::vector<ProbeMatch>> m = parseProbeMatches(reply, id);
  ASSERT_TRUE(m) << m.error();
  ASSERT_EQ(m->size(), 1u);
  EXPECT_EQ(m->front().endpoint, "uuid:c9790c3a-701b-464d-a189-0060351c8ada");
  EXPECT_EQ(m->front().types,
            (std::vector<std::string>{"dn:NetworkVideoTransmitter", "tds:Device"}));
  ASSERT_EQ(m->front().scopes.size(), 7u);
  EXPECT_EQ(m->front().scopes[3], "onvif://www.onvif.org/type/ptz");
  EXPECT_EQ(m->front().scopes[6], "onvif://www.onvif.org/location/");
  EXPECT_EQ(m->front().xaddrs,
            (std::vector<std::string>{"http://192.168.68.111/onvif/device_service",
                                      "http://[fe80::1]/onvif/device_service"}));
  EXPECT_TRUE(parseProbeMatches(reply, ""));
  EXPECT_TRUE(contains(parseProbeMatches(reply, "urn:uuid:other").error(), "not our Probe's"));
  // The recorded reply's template placeholder is no URL.
  EXPECT_TRUE(contains(parseProbeMatches(fixture("ProbeMatches.xml"), id).error(),
                       "XAddrs 'SERVICE_URI': not a URL"));
  EXPECT_TRUE(
      contains(parseProbeMatches(fixture("GetStatus.xml"), id).error(), "expected ProbeMatches"));
}

TEST(OnvifReaders, NumbersDurationsTexts) {
  for (const auto& [text, value] : std::vector<std::pair<const char*, double>>{
           {"1.5", 1.5}, {"+1.5", 1.5}, {"-0", 0.0}, {"1e-3", 0.001}, {"360", 360.0}}) {
    const Result<double> r = readDouble(text, "v");
    ASSERT_TRUE(r) << text << ": " << r.error();
    EXPECT_EQ(*r, value) << text;
  }
  for (const char* bad : {"", "+", "-", "++1", "+-1", "+ 1", "1.5x", " 1", "1 ", "nan", "NaN",
                          "inf", "INF", "infinity", "1e999", "-1e999", "0x10", "1e10"}) {
    const Result<double> r = readDouble(bad, "v");
    EXPECT_FALSE(r) << bad;
    EXPECT_TRUE(contains(r.error(), std::string("v '") + bad + "'")) << r.error();
  }
  for (const auto& [text, seconds] :
       std::vector<std::pair<const char*, double>>{{"PT1.5S", 1.5},
                                                   {"PT1M", 60},
                                                   {"P1DT2H", 93600},
                                                   {"PT0S", 0},
                                                   {"PT1H1M1S", 3661},
                                                   {"PT1093754.348S", 1093754.348},
                                                   {"P2D", 172800}}) {
    const Result<double> r = readDurationS(text, "d");
    ASSERT_TRUE(r) << text << ": " << r.error();
    EXPECT_DOUBLE_EQ(*r, seconds) << text;
  }
  for (const char* bad : {"", "P", "PT", "P1Y", "P1M", "-PT1S", "PT1.5M", "PT1S5", "PTS", "PT1H1H",
                          "PT1S1M", "P1DT", "PT1e9S", "PTNaNS", "PT99999999999S", "1S"}) {
    EXPECT_FALSE(readDurationS(bad, "d")) << bad;
  }
  EXPECT_EQ(formatDuration(1.5), "PT1.5S");
  EXPECT_EQ(formatDuration(10), "PT10S");
  EXPECT_EQ(formatDuration(0.0004), "PT0S");
  EXPECT_TRUE(readInteger("42", "n", 0, 100));
  EXPECT_FALSE(readInteger("42 ", "n", 0, 100));
  EXPECT_FALSE(readInteger("101", "n", 0, 100));
  EXPECT_FALSE(readInteger("99999999999999999999999", "n", 0, 100));
  EXPECT_FALSE(readText(std::string(65, 'a'), "t", 64));
  EXPECT_TRUE(readText("", "t", 64, 0));
  EXPECT_FALSE(readText("", "t", 64));
}

}  // namespace
}  // namespace ptz::onvif
