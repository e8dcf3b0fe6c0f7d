// The ONVIF camera emulator on bytes: the model's angle map, replies in the WSDLs' shapes, the
// head moved through the shared plant, the ONVIF guide's UsernameToken vector, faults.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "common/plant.hpp"
#include "ptz_driver/emulators/emulated_motors.hpp"
#include "ptz_driver/emulators/onvif/http_digest.hpp"
#include "ptz_driver/emulators/onvif/onvif_camera_emulator.hpp"
#include "ptz_driver/emulators/onvif/onvif_discovery.hpp"
#include "ptz_driver/heads/onvif/ws_security.hpp"
#include "ptz_driver/heads/onvif/xml.hpp"

using ptz::PtzPose;
using ptz::driver::OnvifCameraEmulator;
using ptz::driver::OnvifCameraSettings;
using ptz::driver::OnvifModel;
using ptz::driver::OnvifReply;
using ptz::onvif::XmlDocument;

namespace {

const std::string kGeneric = PTZ_SOURCE_DIR "/config/onvif/generic_ptz.yaml";
const std::string kCheap = PTZ_SOURCE_DIR "/config/onvif/cheap_ptz.yaml";
const std::string kXaddr = "http://127.0.0.1:8080";
constexpr double kDeg = M_PI / 180;

std::string envelope(const std::string& body, const std::string& header = "") {
  return "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"><s:Header>" + header +
         "</s:Header><s:Body>" + body + "</s:Body></s:Envelope>";
}
std::string ptzOp(const std::string& op, const std::string& inner = "") {
  return envelope("<" + op + " xmlns=\"http://www.onvif.org/ver20/ptz/wsdl\"><ProfileToken>" +
                  "profile_1</ProfileToken>" + inner + "</" + op + ">");
}
std::string device(const std::string& op) {
  return envelope("<" + op + " xmlns=\"http://www.onvif.org/ver10/device/wsdl\"/>");
}
std::string media(const std::string& op, const std::string& inner = "") {
  return envelope("<" + op + " xmlns=\"http://www.onvif.org/ver10/media/wsdl\">" + inner + "</" +
                  op + ">");
}
std::string absoluteMove(double x, double y, double z, const std::string& speed = "") {
  return ptzOp("AbsoluteMove",
               "<Position><PanTilt xmlns=\"http://www.onvif.org/ver10/schema\" x=\"" +
                   std::to_string(x) + "\" y=\"" + std::to_string(y) +
                   "\"/><Zoom xmlns=\"http://www.onvif.org/ver10/schema\" x=\"" +
                   std::to_string(z) + "\"/></Position>" + speed);
}

// The reply's body element, parsed; the test fails when the reply does not parse.
struct Parsed {
  XmlDocument doc;
  ptz::onvif::XmlNode body() const { return doc.root().child("Body"); }
};
Parsed parse(const OnvifReply& r) {
  Parsed p{XmlDocument::parse(r.body)};
  EXPECT_TRUE(p.doc.ok()) << p.doc.error() << "\n" << r.body;
  return p;
}
std::string faultSubcode(const OnvifReply& r) {
  const Parsed p = parse(r);
  return p.body().find({"Fault", "Code", "Subcode", "Value"}).text();
}

struct Status {
  double x, y, zoom;
  std::string pan_tilt_move;
};
Status status(OnvifCameraEmulator* cam, const PtzPose& now, double t_s) {
  const OnvifReply r = cam->handle(ptzOp("GetStatus"), kXaddr, now, t_s);
  EXPECT_EQ(r.http_status, 200) << r.body;
  const Parsed p = parse(r);
  const auto s = p.body().find({"GetStatusResponse", "PTZStatus"});
  const auto pt = s.find({"Position", "PanTilt"});
  return {std::stod(*pt.attribute("x")), std::stod(*pt.attribute("y")),
          std::stod(*s.find({"Position", "Zoom"}).attribute("x")),
          s.find({"MoveStatus", "PanTilt"}).text()};
}

}  // namespace

TEST(OnvifModel, MapsGenericSpacesToDegreesAndZoomRatios) {
  const OnvifModel m = OnvifModel::load(kGeneric);
  EXPECT_NEAR(m.panRad(0.5), 85 * kDeg, 1e-9);
  EXPECT_NEAR(m.panRad(-1), -170 * kDeg, 1e-9);
  EXPECT_NEAR(m.tiltRad(0), 30 * kDeg, 1e-9);  // -30 .. 90: the middle is 30
  EXPECT_NEAR(m.panNormalised(m.panRad(0.37)), 0.37, 1e-12);
  EXPECT_NEAR(m.tiltNormalised(m.tiltRad(-0.8)), -0.8, 1e-12);
  EXPECT_DOUBLE_EQ(m.panNormalised(400 * kDeg), 1.0);  // clamped
}

TEST(OnvifModel, ZoomMapIsNonLinearMonotonicAndInvertible) {
  for (const std::string& file : {kGeneric, kCheap}) {
    const OnvifModel m = OnvifModel::load(file);
    EXPECT_DOUBLE_EQ(m.zoomRatio(0), m.zoom_ratios.front());
    EXPECT_DOUBLE_EQ(m.zoomRatio(1), m.zoom_ratios.back());
    // Not the straight line between the ends.
    const double linear_mid = (m.zoom_ratios.front() + m.zoom_ratios.back()) / 2;
    EXPECT_GT(std::abs(m.zoomRatio(0.5) - linear_mid), 1.0) << file;
    double last = 0;
    for (int i = 0; i <= 200; ++i) {
      const double z = i / 200.0;
      const double ratio = m.zoomRatio(z);
      EXPECT_GT(ratio, last) << file << " z " << z;
      last = ratio;
      EXPECT_NEAR(m.zoomNormalised(ratio), z, 1e-9) << file;
    }
  }
}

TEST(OnvifEmulator, AbsoluteMoveSettlesAtTheModelsDegrees) {
  const OnvifModel model = OnvifModel::load(kGeneric);
  OnvifCameraEmulator cam(model, {});
  ptz::driver::EmulatedMotors motors(ptz::defaultPlantParams(), PtzPose{0, 0, 1});
  const double t0_s = 1000;  // the host clock; the motors' time is t - t0_s
  const OnvifReply r = cam.handle(absoluteMove(0.5, -0.25, 0.5), kXaddr, motors.pose(0, 0), t0_s);
  ASSERT_EQ(r.http_status, 200) << r.body;
  EXPECT_TRUE(parse(r).body().child("AbsoluteMoveResponse").valid());
  motors.moveTo(0, cam.setpoint(t0_s), 0);
  EXPECT_EQ(status(&cam, motors.pose(0, 0.01), t0_s + 0.01).pan_tilt_move, "MOVING");
  const PtzPose settled = motors.pose(0, 20);
  const Status s = status(&cam, settled, t0_s + 20);
  EXPECT_NEAR(s.x, 0.5, 1e-3);
  EXPECT_NEAR(s.y, -0.25, 1e-3);
  EXPECT_NEAR(s.zoom, 0.5, 1e-3);
  EXPECT_EQ(s.pan_tilt_move, "IDLE");
  // The plant's truth: the model's degrees and zoom ratio.
  EXPECT_NEAR(settled.pan_rad / kDeg, 85, 0.2);
  EXPECT_NEAR(settled.tilt_rad / kDeg, -30 + 0.375 * 120, 0.2);
  EXPECT_NEAR(settled.zoom, model.zoomRatio(0.5), 0.01);
}

TEST(OnvifEmulator, SpeedRampsTheSetpointButACheapCameraIgnoresIt) {
  const std::string slow =
      "<Speed><PanTilt xmlns=\"http://www.onvif.org/ver10/schema\" x=\"0.1\" y=\"0.1\"/></Speed>";
  OnvifCameraEmulator good(OnvifModel::load(kGeneric), {});
  ASSERT_EQ(good.handle(absoluteMove(0.5, 0, 0, slow), kXaddr, {}, 0).http_status, 200);
  // 0.1 x 120 deg/s = 12 deg/s: after 1 s the setpoint is 12 deg on its way to 85.
  EXPECT_NEAR(good.setpoint(1).pan_rad / kDeg, 12, 1e-6);
  EXPECT_NEAR(good.setpoint(100).pan_rad / kDeg, 85, 1e-6);
  OnvifCameraEmulator cheap(OnvifModel::load(kCheap), {});
  ASSERT_EQ(cheap.handle(absoluteMove(0.5, 0, 0, slow), kXaddr, {}, 0).http_status, 200);
  EXPECT_NEAR(cheap.setpoint(0).pan_rad / kDeg, 85, 1e-6);
  // The cheap camera's status comes late; the generic one's at once.
  EXPECT_DOUBLE_EQ(cheap.handle(ptzOp("GetStatus"), kXaddr, {}, 0).delay_s, 0.3);
  EXPECT_DOUBLE_EQ(good.handle(ptzOp("GetStatus"), kXaddr, {}, 0).delay_s, 0.0);
}

TEST(OnvifEmulator, ContinuousMoveRunsUntilStopOrTimeout) {
  OnvifCameraEmulator cam(OnvifModel::load(kGeneric), {});
  const std::string v =
      "<Velocity><PanTilt xmlns=\"http://www.onvif.org/ver10/schema\" x=\"-0.5\" y=\"0\"/>"
      "</Velocity><Timeout>PT2S</Timeout>";
  ASSERT_EQ(cam.handle(ptzOp("ContinuousMove", v), kXaddr, {}, 0).http_status, 200);
  EXPECT_NEAR(cam.setpoint(1).pan_rad / kDeg, -60, 1e-6);    // 60 deg/s
  EXPECT_NEAR(cam.setpoint(10).pan_rad / kDeg, -120, 1e-6);  // stopped by the timeout at 2 s
  const PtzPose there{-50 * kDeg, 0, 1};
  ASSERT_EQ(cam.handle(ptzOp("ContinuousMove", v), kXaddr, there, 20).http_status, 200);
  ASSERT_EQ(cam.handle(ptzOp("Stop", "<PanTilt>true</PanTilt>"), kXaddr, there, 20.5).http_status,
            200);
  EXPECT_NEAR(cam.setpoint(30).pan_rad / kDeg, -50, 1e-6);  // held where the head was
}

TEST(OnvifEmulator, PresetsSetListGotoRemove) {
  OnvifCameraEmulator cam(OnvifModel::load(kGeneric), {});
  const PtzPose here{20 * kDeg, 10 * kDeg, 2};
  const OnvifReply set =
      cam.handle(ptzOp("SetPreset", "<PresetName>door</PresetName>"), kXaddr, here, 0);
  ASSERT_EQ(set.http_status, 200) << set.body;
  const std::string token = parse(set).body().find({"SetPresetResponse", "PresetToken"}).text();
  EXPECT_FALSE(token.empty());
  const Parsed list = parse(cam.handle(ptzOp("GetPresets"), kXaddr, here, 0));
  const auto presets = list.body().child("GetPresetsResponse").children("Preset");
  ASSERT_EQ(presets.size(), 1u);
  EXPECT_EQ(*presets[0].attribute("token"), token);
  EXPECT_EQ(presets[0].child("Name").text(), "door");
  const std::string go = "<PresetToken>" + token + "</PresetToken>";
  ASSERT_EQ(cam.handle(ptzOp("GotoPreset", go), kXaddr, PtzPose{}, 1).http_status, 200);
  EXPECT_NEAR(cam.setpoint(1).pan_rad, here.pan_rad, 1e-9);
  EXPECT_NEAR(cam.setpoint(1).zoom, 2, 1e-9);
  ASSERT_EQ(cam.handle(ptzOp("RemovePreset", go), kXaddr, here, 2).http_status, 200);
  const OnvifReply gone = cam.handle(ptzOp("GotoPreset", go), kXaddr, here, 3);
  EXPECT_EQ(gone.http_status, 400);
  EXPECT_EQ(faultSubcode(gone), "ter:InvalidArgVal");
}

TEST(OnvifEmulator, DeviceAndMediaRepliesInTheWsdlShapes) {
  OnvifCameraEmulator cam(OnvifModel::load(kGeneric), {"admin", "", 3600, "LEFT-1"});
  const double host_s = 1'700'000'000;  // 2023-11-14T22:13:20Z; the camera is an hour ahead
  const Parsed t = parse(cam.handle(device("GetSystemDateAndTime"), kXaddr, {}, host_s));
  const auto utc =
      t.body().find({"GetSystemDateAndTimeResponse", "SystemDateAndTime", "UTCDateTime"});
  EXPECT_EQ(utc.find({"Time", "Hour"}).text(), "23");
  EXPECT_EQ(utc.find({"Time", "Minute"}).text(), "13");
  EXPECT_EQ(utc.find({"Date", "Year"}).text(), "2023");
  const Parsed services = parse(cam.handle(device("GetServices"), kXaddr, {}, host_s));
  const auto list = services.body().child("GetServicesResponse").children("Service");
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[2].child("XAddr").text(), kXaddr + "/onvif/ptz_service");
  const Parsed caps = parse(cam.handle(device("GetCapabilities"), kXaddr, {}, host_s));
  EXPECT_EQ(caps.body().find({"GetCapabilitiesResponse", "Capabilities", "PTZ", "XAddr"}).text(),
            kXaddr + "/onvif/ptz_service");
  const Parsed info = parse(cam.handle(device("GetDeviceInformation"), kXaddr, {}, host_s));
  EXPECT_EQ(info.body().find({"GetDeviceInformationResponse", "SerialNumber"}).text(), "LEFT-1");
  const Parsed profiles = parse(cam.handle(media("GetProfiles"), kXaddr, {}, host_s));
  const auto p = profiles.body().find({"GetProfilesResponse", "Profiles"});
  EXPECT_EQ(*p.attribute("token"), "profile_1");
  EXPECT_EQ(p.find({"VideoEncoderConfiguration", "Encoding"}).text(), "H264");
  EXPECT_EQ(p.find({"VideoEncoderConfiguration", "Resolution", "Width"}).text(), "640");
  EXPECT_EQ(p.find({"PTZConfiguration", "NodeToken"}).text(), "node_1");
  const Parsed uri = parse(cam.handle(
      media("GetStreamUri", "<ProfileToken>profile_1</ProfileToken>"), kXaddr, {}, host_s));
  EXPECT_EQ(uri.body().find({"GetStreamUriResponse", "MediaUri", "Uri"}).text().rfind("rtsp://", 0),
            0u);
  const Parsed nodes = parse(cam.handle(ptzOp("GetNodes"), kXaddr, {}, host_s));
  EXPECT_TRUE(nodes.body()
                  .find({"GetNodesResponse", "PTZNode", "SupportedPTZSpaces",
                         "AbsolutePanTiltPositionSpace", "XRange", "Max"})
                  .valid());
  const OnvifReply options = cam.handle(
      ptzOp("GetConfigurationOptions", "<ConfigurationToken>ptz_config_1</ConfigurationToken>"),
      kXaddr, {}, host_s);
  EXPECT_EQ(options.http_status, 200) << options.body;
}

TEST(OnvifEmulator, UsernameTokenOfTheOnvifGuide) {
  // ONVIF Application Programmer's Guide, 6.1.1.3: this nonce, created and password give
  // this digest. The camera's clock set to that instant (host clock + offset).
  const std::string created = "2010-09-16T07:50:45Z";
  const double host_s = 1'800'000'000;
  OnvifCameraSettings s;
  s.user = "user";
  s.password = "userpassword";
  s.clock_offset_s = *ptz::onvif::parseXsDateTime(created) - host_s;
  OnvifCameraEmulator cam(OnvifModel::load(kGeneric), s);
  const auto token = [&](const std::string& user, const std::string& digest,
                         const std::string& when) {
    return "<Security xmlns=\"http://docs.oasis-open.org/wss/2004/01/"
           "oasis-200401-wss-wssecurity-secext-1.0.xsd\"><UsernameToken><Username>" +
           user + "</Username><Password>" + digest +
           "</Password><Nonce>LKqI6G/AikKCQrN0zqZFlg==</Nonce><Created "
           "xmlns=\"http://docs.oasis-open.org/wss/2004/01/"
           "oasis-200401-wss-wssecurity-utility-1.0.xsd\">" +
           when + "</Created></UsernameToken></Security>";
  };
  const std::string op = "<GetDeviceInformation xmlns=\"http://www.onvif.org/ver10/device/wsdl\"/>";
  const std::string good = "tuOSpGlFlIXsozq4HFNeeGeFLEI=";
  EXPECT_EQ(cam.handle(envelope(op, token("user", good, created)), kXaddr, {}, host_s).http_status,
            200);
  EXPECT_EQ(
      cam.handle(envelope(op, token("user", good, created)), kXaddr, {}, host_s + 4.5).http_status,
      200);
  // Refused: no token, another digest, another user, 6 s off the camera's clock.
  for (const std::string& header :
       {std::string(), token("user", "AAAApGlFlIXsozq4HFNeeGeFLEI=", created),
        token("admin", good, created)}) {
    const OnvifReply r = cam.handle(envelope(op, header), kXaddr, {}, host_s);
    EXPECT_EQ(r.http_status, 400);
    EXPECT_EQ(faultSubcode(r), "ter:NotAuthorized");
  }
  const OnvifReply late =
      cam.handle(envelope(op, token("user", good, created)), kXaddr, {}, host_s + 6);
  EXPECT_EQ(faultSubcode(late), "ter:NotAuthorized");
  EXPECT_EQ(cam.authRefused(), 4);
  // The clock is open to all.
  EXPECT_EQ(cam.handle(device("GetSystemDateAndTime"), kXaddr, {}, host_s).http_status, 200);
  // A token made by the shared code for the camera's clock passes.
  const auto made = ptz::onvif::makeUsernameToken("user", "userpassword", cam.cameraNow(host_s));
  EXPECT_EQ(
      cam.handle(envelope(op, ptz::onvif::securityHeader(made)), kXaddr, {}, host_s).http_status,
      200);
}

TEST(OnvifEmulator, FaultsForBadRequests) {
  OnvifCameraEmulator cam(OnvifModel::load(kGeneric), {});
  const auto check = [&](const std::string& request, int http, const std::string& code,
                         const std::string& subcode) {
    const OnvifReply r = cam.handle(request, kXaddr, {}, 0);
    EXPECT_EQ(r.http_status, http) << request;
    const Parsed p = parse(r);
    EXPECT_EQ(p.body().find({"Fault", "Code", "Value"}).text(), code) << request;
    if (!subcode.empty()) {
      EXPECT_EQ(faultSubcode(r), subcode) << request;
    }
  };
  check("<s:Envelope xmlns:s=", 400, "env:Sender", "ter:WellFormed");
  check("", 400, "env:Sender", "ter:WellFormed");
  check("<Envelope><Body/></Envelope>", 400, "env:VersionMismatch", "");
  check(envelope(""), 400, "env:Sender", "ter:InvalidArgVal");
  check(device("Reboot"), 500, "env:Receiver", "ter:ActionNotSupported");
  check(envelope("<GetStatus xmlns=\"urn:other\"/>"), 500, "env:Receiver",
        "ter:ActionNotSupported");
  check(absoluteMove(2, 0, 0), 400, "env:Sender", "ter:InvalidArgVal");
  check(ptzOp("AbsoluteMove", "<Position><PanTilt x=\"nan\" y=\"0\"/></Position>"), 400,
        "env:Sender", "ter:InvalidArgVal");
  check(ptzOp("AbsoluteMove", "<Position><PanTilt x=\"0.1abc\" y=\"0\"/></Position>"), 400,
        "env:Sender", "ter:InvalidArgVal");
  check(ptzOp("AbsoluteMove"), 400, "env:Sender", "ter:InvalidArgVal");
  check(envelope("<GetStatus xmlns=\"http://www.onvif.org/ver20/ptz/wsdl\"><ProfileToken>x"
                 "</ProfileToken></GetStatus>"),
        400, "env:Sender", "ter:InvalidArgVal");
  check(ptzOp("ContinuousMove",
              "<Velocity><PanTilt x=\"1\" y=\"0\"/></Velocity><Timeout>5 s"
              "</Timeout>"),
        400, "env:Sender", "ter:InvalidArgVal");
  check("<!DOCTYPE x [<!ENTITY a \"aaaa\">]><x>&a;</x>", 400, "env:Sender", "ter:WellFormed");
  // Bytes that are not UTF-8 (libxml2 quotes them in its message): the fault is still XML.
  check(
      "<s:Envelope xmlns:s=\"http://www.w3.org/2\xff\xff"
      "003/05/soap-envelope\"><s:Body/>"
      "</s:Envelope>",
      400, "env:Sender", "ter:WellFormed");
  check(ptzOp("GetStatus")
            .replace(ptzOp("GetStatus").find("profile_1"), 9, std::string(39, 'p') + "\xc3\xa9"),
        400, "env:Sender", "ter:InvalidArgVal");  // a token cut inside a character
  EXPECT_EQ(cam.faults(), 15);
  // Nothing of that moved the head.
  EXPECT_NEAR(cam.setpoint(10).pan_rad, 0, 1e-12);
}

TEST(OnvifDiscoveryEmulator, ReadsProbesAsClientsSendThem) {
  // npm onvif's Probe: default namespace, no prefixes, an empty Scopes.
  const std::string npm =
      "<Envelope xmlns=\"http://www.w3.org/2003/05/soap-envelope\" "
      "xmlns:dn=\"http://www.onvif.org/ver10/network/wsdl\"><Header>"
      "<wsa:MessageID xmlns:wsa=\"http://schemas.xmlsoap.org/ws/2004/08/addressing\">urn:uuid:42"
      "</wsa:MessageID><wsa:Action xmlns:wsa=\"http://schemas.xmlsoap.org/ws/2004/08/addressing\">"
      "http://schemas.xmlsoap.org/ws/2005/04/discovery/Probe</wsa:Action></Header><Body>"
      "<Probe xmlns=\"http://schemas.xmlsoap.org/ws/2005/04/discovery\">"
      "<Types>dn:NetworkVideoTransmitter</Types><Scopes /></Probe></Body></Envelope>";
  const ptz::driver::ProbeRead r = ptz::driver::readProbe(npm);
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.message_id, "urn:uuid:42");
  EXPECT_TRUE(r.wants_camera);
  std::string printers = npm;
  printers.replace(printers.find("dn:NetworkVideoTransmitter"), 26, "dn:Printer");
  EXPECT_FALSE(ptz::driver::readProbe(printers).wants_camera);
  std::string hello = npm;
  hello.replace(hello.find("discovery/Probe"), 15, "discovery/Hello");
  EXPECT_FALSE(ptz::driver::readProbe(hello).ok);
  EXPECT_FALSE(ptz::driver::readProbe(std::string(600 * 1024, ' ')).ok);
  EXPECT_EQ(ptz::driver::scopeEncoded("ptz-sim left/1"), "ptz-sim%20left%2F1");
}

TEST(HttpDigest, TheRfc2617Example) {
  // RFC 2617 section 3.5: Mufasa's request, response 6629fae49393a05397450978507c4ef1.
  ptz::driver::DigestCredentials c{"Mufasa", "Circle Of Life", "testrealm@host.com",
                                   "dcd98b7102dd2f0e8b11d0f600bfb0c093"};
  const std::string auth =
      "Digest username=\"Mufasa\", realm=\"testrealm@host.com\", "
      "nonce=\"dcd98b7102dd2f0e8b11d0f600bfb0c093\", uri=\"/dir/index.html\", qop=auth, "
      "nc=00000001, cnonce=\"0a4f113b\", response=\"6629fae49393a05397450978507c4ef1\", "
      "opaque=\"5ccc069c403ebaf9f0171e9517f40e41\"";
  std::string why;
  EXPECT_TRUE(ptz::driver::digestValid(auth, "GET", "/dir/index.html", c, &why)) << why;
  EXPECT_FALSE(ptz::driver::digestValid(auth, "POST", "/dir/index.html", c, &why));
  c.password = "Circle of Life";
  EXPECT_FALSE(ptz::driver::digestValid(auth, "GET", "/dir/index.html", c, &why));
  EXPECT_EQ(why, "wrong response (wrong password?)");
  EXPECT_FALSE(ptz::driver::digestValid("Basic TXVmYXNhOg==", "GET", "/", c, &why));
  EXPECT_FALSE(ptz::driver::digestValid("Digest username=\"Mufasa", "GET", "/", c, &why));
  EXPECT_FALSE(ptz::driver::digestValid("Digest " + std::string(4000, 'a'), "GET", "/", c, &why));
  EXPECT_EQ(ptz::driver::md5Hex(""), "d41d8cd98f00b204e9800998ecf8427e");  // RFC 1321
}
