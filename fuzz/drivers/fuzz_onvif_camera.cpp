// The camera end of ONVIF: what ptz-sim --onvif-port does with a request's body (the ONVIF
// camera emulator: libxml2 through ptz_onvif_core, the UsernameToken check, the operations).
// Input: one byte (bit 0: the cheap model; bit 1: a password set), then the SOAP bytes.
// Properties: every reply is a well-formed SOAP 1.2 envelope, HTTP 200 with the operation's
// Response or 400/500 with a Fault (a password set: nothing but GetSystemDateAndTime and faults
// pass without a token that is valid: user, digest and Created within 5 s; libFuzzer's
// comparison tracing does learn the digest); the setpoint stays finite and within the model's
// ranges.
#include <cmath>
#include <string>

#include "fuzz/fuzz_support.hpp"
#include "ptz_driver/emulators/onvif/onvif_camera_emulator.hpp"
#include "ptz_driver/heads/onvif/ws_security.hpp"
#include "ptz_driver/heads/onvif/xml.hpp"

namespace driver = ptz::driver;

namespace {

driver::OnvifModel model(bool cheap) {
  driver::OnvifModel m;
  m.name = "fuzz";
  m.manufacturer = "fuzz & <co>";
  m.model = "F";
  m.pan_min_rad = -170 * M_PI / 180;
  m.pan_max_rad = -m.pan_min_rad;
  m.tilt_min_rad = -30 * M_PI / 180;
  m.tilt_max_rad = 90 * M_PI / 180;
  m.pan_tilt_speed_max_rad_s = 2;
  m.zoom_normalised = {0, 0.5, 1};
  m.zoom_ratios = {1, 2, 10};
  m.cheap = cheap;
  m.status_delay_ms = cheap ? 300 : 0;
  return m;
}

// Whether the request carries a token the camera must accept at camera time t_s.
bool validToken(const std::string& request, double t_s) {
  const auto doc = ptz::onvif::XmlDocument::parse(request);
  if (!doc.ok()) return false;
  const auto token = doc.root().find({"Header", "Security", "UsernameToken"});
  const auto nonce = ptz::onvif::base64Decode(token.child("Nonce").text());
  const std::string created = token.child("Created").text();
  const auto created_s = ptz::onvif::parseXsDateTime(created);
  return nonce && created_s && std::abs(*created_s - t_s) <= 5 &&
         token.child("Username").text() == "admin" &&
         ptz::onvif::passwordDigest(*nonce, created, "secret") == token.child("Password").text();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const bool cheap = data[0] & 1, password = data[0] & 2;
  const std::string request(reinterpret_cast<const char*>(data + 1), size - 1);
  driver::OnvifCameraSettings settings;
  settings.password = password ? "secret" : "";
  driver::OnvifCameraEmulator camera(model(cheap), settings, ptz::PtzPose{0.1, 0.2, 2});
  const ptz::PtzPose now{0.5, -0.2, 3.0};
  // The same request twice (a move, then a status after it), a second apart.
  for (double t_s : {1000.0, 1001.0}) {
    const driver::OnvifReply r = camera.handle(request, "http://127.0.0.1:8000", now, t_s);
    const auto doc = ptz::onvif::XmlDocument::parse(r.body);
    FUZZ_CHECK(doc.ok(), "the reply is not XML: " + doc.error());
    const ptz::onvif::XmlNode body = doc.root().child("Body");
    FUZZ_CHECK(doc.root().localName() == "Envelope" && body.valid(), "no SOAP envelope");
    const auto content = body.children();
    FUZZ_CHECK(content.size() == 1, "the Body holds " + std::to_string(content.size()));
    const std::string element(content[0].localName());
    if (r.http_status == 200) {
      FUZZ_CHECK(element.size() > 8 && element.compare(element.size() - 8, 8, "Response") == 0,
                 "200 with " + element);
      FUZZ_CHECK(!password || element == "GetSystemDateAndTimeResponse" || validToken(request, t_s),
                 "answered without a valid token: " + element);
    } else {
      FUZZ_CHECK(r.http_status == 400 || r.http_status == 500,
                 "HTTP " + std::to_string(r.http_status));
      FUZZ_CHECK(element == "Fault", "an error without a Fault: " + element);
    }
    FUZZ_CHECK(r.delay_s == 0 || (cheap && r.delay_s == 0.3), "delay " + std::to_string(r.delay_s));
    for (double at_s : {t_s, t_s + 0.5, t_s + 1e6}) {
      const ptz::PtzPose sp = camera.setpoint(at_s);
      const driver::OnvifModel& m = camera.model();
      FUZZ_CHECK(std::isfinite(sp.pan_rad) && sp.pan_rad >= m.pan_min_rad - 1e-9 &&
                     sp.pan_rad <= m.pan_max_rad + 1e-9,
                 "pan setpoint " + std::to_string(sp.pan_rad));
      FUZZ_CHECK(std::isfinite(sp.tilt_rad) && sp.tilt_rad >= m.tilt_min_rad - 1e-9 &&
                     sp.tilt_rad <= m.tilt_max_rad + 1e-9,
                 "tilt setpoint " + std::to_string(sp.tilt_rad));
      FUZZ_CHECK(std::isfinite(sp.zoom) && sp.zoom >= 1 && sp.zoom <= 10,
                 "zoom setpoint " + std::to_string(sp.zoom));
    }
  }
  return 0;
}
