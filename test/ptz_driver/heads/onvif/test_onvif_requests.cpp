// ptz_onvif's requests, read back with the XML reader: element names and namespaces as the WSDLs
// define them, attributes, escaped texts, numbers that read back exactly; a few byte for byte.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ptz_driver/heads/onvif/requests.hpp"
#include "ptz_driver/heads/onvif/soap.hpp"

namespace ptz::onvif {
namespace {

// The request in an envelope, parsed; the Body's one child.
struct Parsed {
  XmlDocument doc;
  XmlNode request;
};

Parsed parse(const Request& r) {
  Parsed p{XmlDocument::parse(envelope(r.body, std::nullopt)), {}};
  EXPECT_TRUE(p.doc.ok()) << p.doc.error() << "\n" << r.body;
  const XmlNode body = p.doc.root().child("Body");
  EXPECT_EQ(body.namespaceUri(), kSoapNs);
  const auto parts = body.children();
  EXPECT_EQ(parts.size(), 1u);
  if (!parts.empty()) p.request = parts[0];
  return p;
}

// The element names (local) and namespaces of a node's children, in order.
std::vector<std::string> childNames(const XmlNode& node, std::string_view ns) {
  std::vector<std::string> names;
  for (const XmlNode& c : node.children()) {
    EXPECT_EQ(c.namespaceUri(), ns) << c.localName();
    names.emplace_back(c.localName());
  }
  return names;
}

using Names = std::vector<std::string>;

TEST(OnvifRequests, DeviceAndMediaShapes) {
  struct Case {
    Request request;
    std::string_view ns;
    const char* name;
    Names children;
  };
  const Case cases[] = {
      {getSystemDateAndTime(), kDeviceNs, "GetSystemDateAndTime", {}},
      {getCapabilities(), kDeviceNs, "GetCapabilities", {"Category"}},
      {getServices(), kDeviceNs, "GetServices", {"IncludeCapability"}},
      {getProfiles(), kMediaNs, "GetProfiles", {}},
      {getStreamUri("main"), kMediaNs, "GetStreamUri", {"StreamSetup", "ProfileToken"}},
  };
  for (const Case& c : cases) {
    const Parsed p = parse(c.request);
    EXPECT_EQ(p.request.localName(), c.name);
    EXPECT_EQ(p.request.namespaceUri(), c.ns);
    EXPECT_EQ(childNames(p.request, c.ns), c.children) << c.name;
    EXPECT_EQ(c.request.action, std::string(c.ns) + "/" + c.name);
  }
  EXPECT_EQ(parse(getCapabilities()).request.child("Category").text(), "All");
  EXPECT_EQ(parse(getServices()).request.child("IncludeCapability").text(), "false");
  const Parsed uri = parse(getStreamUri("main"));
  const XmlNode setup = uri.request.child("StreamSetup");
  EXPECT_EQ(childNames(setup, kSchemaNs), (Names{"Stream", "Transport"}));
  EXPECT_EQ(setup.child("Stream").text(), "RTP-Unicast");
  EXPECT_EQ(setup.find({"Transport", "Protocol"}).text(), "RTSP");
  EXPECT_EQ(setup.find({"Transport", "Protocol"}).namespaceUri(), kSchemaNs);
  EXPECT_EQ(uri.request.child("ProfileToken").text(), "main");
  EXPECT_EQ(getSystemDateAndTime().action,
            "http://www.onvif.org/ver10/device/wsdl/GetSystemDateAndTime");
}

TEST(OnvifRequests, PtzShapes) {
  struct Case {
    Request request;
    const char* name;
    Names children;
  };
  const PtzVector v{Vector2D{0.5, -0.25, ""}, Vector1D{0.75, ""}};
  const Case cases[] = {
      {getNodes(), "GetNodes", {}},
      {getConfigurationOptions("cfg"), "GetConfigurationOptions", {"ConfigurationToken"}},
      {getStatus("p"), "GetStatus", {"ProfileToken"}},
      {absoluteMove("p", v), "AbsoluteMove", {"ProfileToken", "Position"}},
      {absoluteMove("p", v, v), "AbsoluteMove", {"ProfileToken", "Position", "Speed"}},
      {relativeMove("p", v), "RelativeMove", {"ProfileToken", "Translation"}},
      {relativeMove("p", v, v), "RelativeMove", {"ProfileToken", "Translation", "Speed"}},
      {continuousMove("p", v), "ContinuousMove", {"ProfileToken", "Velocity"}},
      {continuousMove("p", v, 1.5), "ContinuousMove", {"ProfileToken", "Velocity", "Timeout"}},
      {stop("p", true, false), "Stop", {"ProfileToken", "PanTilt", "Zoom"}},
      {getPresets("p"), "GetPresets", {"ProfileToken"}},
      {gotoPreset("p", "1"), "GotoPreset", {"ProfileToken", "PresetToken"}},
      {gotoPreset("p", "1", v), "GotoPreset", {"ProfileToken", "PresetToken", "Speed"}},
      {setPreset("p", "door"), "SetPreset", {"ProfileToken", "PresetName"}},
      {setPreset("p", "door", "3"), "SetPreset", {"ProfileToken", "PresetName", "PresetToken"}},
      {setPreset("p", ""), "SetPreset", {"ProfileToken"}},
  };
  for (const Case& c : cases) {
    const Parsed p = parse(c.request);
    EXPECT_EQ(p.request.localName(), c.name);
    EXPECT_EQ(p.request.namespaceUri(), kPtzNs);
    EXPECT_EQ(childNames(p.request, kPtzNs), c.children) << c.name;
    EXPECT_EQ(c.request.action, std::string("http://www.onvif.org/ver20/ptz/wsdl/") + c.name);
  }
}

TEST(OnvifRequests, VectorsCarryAttributesInTheSchemaNamespace) {
  const std::string pt_space = "http://www.onvif.org/ver10/tptz/PanTiltSpaces/PositionGenericSpace";
  const PtzVector position{Vector2D{0.5, -0.25, pt_space}, Vector1D{0.75, ""}};
  const PtzVector speed{std::nullopt, Vector1D{1.0, "urn:zoom&speed"}};
  const Parsed p = parse(absoluteMove("prof", position, speed));
  const XmlNode pt = p.request.find({"Position", "PanTilt"});
  EXPECT_EQ(pt.namespaceUri(), kSchemaNs);
  EXPECT_EQ(pt.attribute("x").value_or(""), "0.5");
  EXPECT_EQ(pt.attribute("y").value_or(""), "-0.25");
  EXPECT_EQ(pt.attribute("space").value_or(""), pt_space);
  const XmlNode zoom = p.request.find({"Position", "Zoom"});
  EXPECT_EQ(zoom.namespaceUri(), kSchemaNs);
  EXPECT_EQ(zoom.attribute("x").value_or(""), "0.75");
  EXPECT_FALSE(zoom.attribute("space"));  // left out: the camera's default space
  EXPECT_FALSE(p.request.find({"Speed", "PanTilt"}).valid());
  EXPECT_EQ(p.request.find({"Speed", "Zoom"}).attribute("space").value_or(""), "urn:zoom&speed");
  EXPECT_EQ(childNames(p.request.child("Position"), kSchemaNs), (Names{"PanTilt", "Zoom"}));
}

TEST(OnvifRequests, ExactBytes) {
  EXPECT_EQ(stop("p&1", true, false).body,
            "<tptz:Stop><tptz:ProfileToken>p&amp;1</tptz:ProfileToken><tptz:PanTilt>true"
            "</tptz:PanTilt><tptz:Zoom>false</tptz:Zoom></tptz:Stop>");
  EXPECT_EQ(continuousMove("main", {Vector2D{0.1, -1, ""}, Vector1D{0, ""}}, 1.5).body,
            "<tptz:ContinuousMove><tptz:ProfileToken>main</tptz:ProfileToken><tptz:Velocity>"
            "<tt:PanTilt x=\"0.1\" y=\"-1\"/><tt:Zoom x=\"0\"/></tptz:Velocity>"
            "<tptz:Timeout>PT1.5S</tptz:Timeout></tptz:ContinuousMove>");
  EXPECT_EQ(absoluteMove("main", {std::nullopt, Vector1D{1e-7, "z"}}).body,
            "<tptz:AbsoluteMove><tptz:ProfileToken>main</tptz:ProfileToken><tptz:Position>"
            "<tt:Zoom x=\"1e-07\" space=\"z\"/></tptz:Position></tptz:AbsoluteMove>");
  EXPECT_EQ(getNodes().body, "<tptz:GetNodes/>");
  const std::string env = envelope("<tptz:GetNodes/>", std::nullopt);
  EXPECT_EQ(env.rfind("<?xml version=\"1.0\" encoding=\"UTF-8\"?><s:Envelope ", 0), 0u);
  for (const char* ns : {"xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"",
                         "xmlns:tds=\"http://www.onvif.org/ver10/device/wsdl\"",
                         "xmlns:trt=\"http://www.onvif.org/ver10/media/wsdl\"",
                         "xmlns:tptz=\"http://www.onvif.org/ver20/ptz/wsdl\"",
                         "xmlns:tt=\"http://www.onvif.org/ver10/schema\"", "xmlns:wsse="}) {
    EXPECT_NE(env.find(ns), std::string::npos) << ns;
  }
  EXPECT_EQ(env.find("<s:Header>"), std::string::npos);
  EXPECT_NE(env.find("<s:Body><tptz:GetNodes/></s:Body></s:Envelope>"), std::string::npos);
}

TEST(OnvifRequests, TextsAreEscaped) {
  const std::string hostile = "a<b>&\"c'</tptz:ProfileToken><x/>";
  for (const Request& r :
       {getStatus(hostile), getStreamUri(hostile), gotoPreset(hostile, hostile),
        setPreset(hostile, hostile, hostile), getConfigurationOptions(hostile)}) {
    const Parsed p = parse(r);
    for (const XmlNode& c : p.request.children()) {
      if (c.localName() == "StreamSetup") continue;
      EXPECT_EQ(c.text(), hostile) << c.localName();
    }
  }
}

TEST(OnvifRequests, NumbersReadBackExactly) {
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> any(-1.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    const double x = i == 0 ? 1.0 / 3.0 : any(random) * std::pow(10.0, i % 7 - 3);
    const Parsed p = parse(absoluteMove("p", {Vector2D{x, -x, ""}, std::nullopt}));
    const std::string text = p.request.find({"Position", "PanTilt"}).attribute("x").value_or("");
    EXPECT_EQ(std::strtod(text.c_str(), nullptr), x) << text;
    const Result<double> back = readDouble(text, "x");
    ASSERT_TRUE(back) << back.error();
    EXPECT_EQ(*back, x);
  }
  EXPECT_THROW(absoluteMove("p", {Vector2D{std::nan(""), 0, ""}, std::nullopt}),
               std::invalid_argument);
  EXPECT_THROW(continuousMove("p", {}, -1.0), std::invalid_argument);
}

TEST(OnvifRequests, SecurityHeaderInTheEnvelope) {
  const UsernameToken token = makeUsernameToken("admin", "pw", 1419448477.0);
  const XmlDocument doc = XmlDocument::parse(envelope(getNodes().body, token));
  ASSERT_TRUE(doc.ok()) << doc.error();
  const XmlNode header = doc.root().child("Header");
  EXPECT_EQ(header.namespaceUri(), kSoapNs);
  const XmlNode security = header.child("Security");
  EXPECT_EQ(security.namespaceUri(), kWsseNs);
  EXPECT_EQ(security.attribute("mustUnderstand").value_or(""), "1");
  const XmlNode ut = security.child("UsernameToken");
  EXPECT_EQ(ut.child("Username").text(), "admin");
  EXPECT_EQ(ut.child("Created").text(), "2014-12-24T19:14:37.000Z");
  const auto nonce = base64Decode(ut.child("Nonce").text());
  ASSERT_TRUE(nonce);
  EXPECT_EQ(ut.child("Password").text(), passwordDigest(*nonce, "2014-12-24T19:14:37.000Z", "pw"));
  EXPECT_EQ(doc.root().child("Body").child("GetNodes").namespaceUri(), kPtzNs);
}

TEST(OnvifDiscovery, ProbeMessage) {
  const std::string id = randomMessageId();
  EXPECT_EQ(id.size(), 9u + 36u) << id;
  EXPECT_EQ(id.rfind("urn:uuid:", 0), 0u);
  EXPECT_EQ(id[9 + 14], '4') << id;  // version 4
  EXPECT_NE(randomMessageId(), id);
  const XmlDocument doc = XmlDocument::parse(probeMessage(id));
  ASSERT_TRUE(doc.ok()) << doc.error();
  EXPECT_EQ(doc.root().namespaceUri(), kSoapNs);
  const XmlNode header = doc.root().child("Header");
  EXPECT_EQ(childNames(header, kAddressingNs), (Names{"Action", "MessageID", "ReplyTo", "To"}));
  EXPECT_EQ(header.child("Action").text(), "http://schemas.xmlsoap.org/ws/2005/04/discovery/Probe");
  EXPECT_EQ(header.child("MessageID").text(), id);
  EXPECT_EQ(header.child("To").text(), "urn:schemas-xmlsoap-org:ws:2005:04:discovery");
  const XmlNode probe = doc.root().find({"Body", "Probe"});
  EXPECT_EQ(probe.namespaceUri(), kDiscoveryNs);
  EXPECT_EQ(childNames(probe, kDiscoveryNs), (Names{"Types"}));
  EXPECT_EQ(probe.child("Types").text(), "dn:NetworkVideoTransmitter");
  EXPECT_NE(probeMessage("a&b").find("<a:MessageID>a&amp;b</a:MessageID>"), std::string::npos);
}

}  // namespace
}  // namespace ptz::onvif
