#include "ptz_driver/emulators/onvif/onvif_camera_emulator.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <stdexcept>

#include "ptz_driver/heads/onvif/ws_security.hpp"

namespace ptz::driver {

namespace {

constexpr const char* kSoapNs = "http://www.w3.org/2003/05/soap-envelope";
constexpr const char* kDeviceNs = "http://www.onvif.org/ver10/device/wsdl";
constexpr const char* kMediaNs = "http://www.onvif.org/ver10/media/wsdl";
constexpr const char* kPtzNs = "http://www.onvif.org/ver20/ptz/wsdl";
constexpr const char* kProfile = "profile_1";
constexpr const char* kNode = "node_1";
constexpr const char* kPtzConfig = "ptz_config_1";
constexpr const char* kSpaces = "http://www.onvif.org/ver10/tptz/";
// Zoom speed 1: the whole normalised zoom range in this time.
constexpr double kZoomFullRangeS = 2.0;
// MoveStatus IDLE once the plant is this close to where the move goes (normalised).
constexpr double kIdleTolerance = 0.002;

// A SOAP fault: Code (env:Sender or env:Receiver), ONVIF subcodes, reason.
struct Fault : std::runtime_error {
  Fault(std::string code_, std::string subcode_, std::string subsubcode_, const std::string& reason)
      : std::runtime_error(reason),
        code(std::move(code_)),
        subcode(std::move(subcode_)),
        subsubcode(std::move(subsubcode_)) {}
  std::string code, subcode, subsubcode;
};

Fault invalidArg(const std::string& subsub, const std::string& reason) {
  return Fault("env:Sender", "ter:InvalidArgVal", subsub, reason);
}

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

std::string envelope(const std::string& body) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<env:Envelope xmlns:env=\"http://www.w3.org/2003/05/soap-envelope\" "
         "xmlns:tt=\"http://www.onvif.org/ver10/schema\" "
         "xmlns:tds=\"http://www.onvif.org/ver10/device/wsdl\" "
         "xmlns:trt=\"http://www.onvif.org/ver10/media/wsdl\" "
         "xmlns:tptz=\"http://www.onvif.org/ver20/ptz/wsdl\" "
         "xmlns:ter=\"http://www.onvif.org/ver10/error\">"
         "<env:Body>" +
         body + "</env:Body></env:Envelope>\n";
}

// A fault's reason as plain ASCII, at most 200 bytes: it may quote the request (libxml2's
// messages quote bytes that are not UTF-8, a token cut at 40 bytes may split a character), and
// the reply must stay well-formed XML (fuzz_onvif_camera's first find).
std::string plainReason(const std::string& reason) {
  std::string out = reason.substr(0, 200);
  for (char& ch : out) {
    const auto b = static_cast<unsigned char>(ch);
    if (b >= 0x80 || (b < 0x20 && b != '\n' && b != '\t') || b == 0x7F) ch = '?';
  }
  return out;
}

std::string faultBody(const Fault& f) {
  std::string sub;
  if (!f.subcode.empty()) {
    sub = "<env:Subcode><env:Value>" + f.subcode + "</env:Value>";
    if (!f.subsubcode.empty()) {
      sub += "<env:Subcode><env:Value>" + f.subsubcode + "</env:Value></env:Subcode>";
    }
    sub += "</env:Subcode>";
  }
  return "<env:Fault><env:Code><env:Value>" + f.code + "</env:Value>" + sub +
         "</env:Code><env:Reason><env:Text xml:lang=\"en\">" +
         onvif::xmlEscape(plainReason(f.what())) + "</env:Text></env:Reason></env:Fault>";
}

// A number of an attribute or element: all of the text, finite.
double parseNumber(const std::string& text, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw invalidArg("ter:InvalidArgs", what + ": not a number: '" + text.substr(0, 40) + "'");
  }
  return v;
}

std::optional<double> attributeNumber(const onvif::XmlNode& n, const char* name,
                                      const std::string& what) {
  if (!n.valid()) return std::nullopt;
  const auto a = n.attribute(name);
  if (!a) return std::nullopt;
  return parseNumber(*a, what + "@" + name);
}

std::string range(const char* name, double lo, double hi) {
  return std::string("<tt:") + name + "><tt:Min>" + num(lo) + "</tt:Min><tt:Max>" + num(hi) +
         "</tt:Max></tt:" + name + ">";
}

std::string space2(const char* element, const std::string& uri, double lo, double hi) {
  return std::string("<tt:") + element + "><tt:URI>" + uri + "</tt:URI>" + range("XRange", lo, hi) +
         range("YRange", lo, hi) + "</tt:" + element + ">";
}

std::string space1(const char* element, const std::string& uri, double lo, double hi) {
  return std::string("<tt:") + element + "><tt:URI>" + uri + "</tt:URI>" + range("XRange", lo, hi) +
         "</tt:" + element + ">";
}

// absolute: the camera takes AbsoluteMove (most do; some offer ContinuousMove alone).
std::string ptzSpaces(bool absolute) {
  const std::string pt = std::string(kSpaces) + "PanTiltSpaces/";
  const std::string z = std::string(kSpaces) + "ZoomSpaces/";
  return (absolute ? space2("AbsolutePanTiltPositionSpace", pt + "PositionGenericSpace", -1, 1) +
                         space1("AbsoluteZoomPositionSpace", z + "PositionGenericSpace", 0, 1)
                   : std::string()) +
         space2("RelativePanTiltTranslationSpace", pt + "TranslationGenericSpace", -1, 1) +
         space1("RelativeZoomTranslationSpace", z + "TranslationGenericSpace", -1, 1) +
         space2("ContinuousPanTiltVelocitySpace", pt + "VelocityGenericSpace", -1, 1) +
         space1("ContinuousZoomVelocitySpace", z + "VelocityGenericSpace", -1, 1) +
         space1("PanTiltSpeedSpace", pt + "GenericSpeedSpace", 0, 1) +
         space1("ZoomSpeedSpace", z + "ZoomGenericSpeedSpace", 0, 1);
}

std::string ptzConfiguration(const char* element) {
  const std::string pt = std::string(kSpaces) + "PanTiltSpaces/";
  const std::string z = std::string(kSpaces) + "ZoomSpaces/";
  return std::string("<") + element + " token=\"" + kPtzConfig +
         "\"><tt:Name>PTZ</tt:Name><tt:UseCount>1</tt:UseCount><tt:NodeToken>" + kNode +
         "</tt:NodeToken><tt:DefaultAbsolutePantTiltPositionSpace>" + pt +
         "PositionGenericSpace</tt:DefaultAbsolutePantTiltPositionSpace>"
         "<tt:DefaultAbsoluteZoomPositionSpace>" +
         z +
         "PositionGenericSpace</tt:DefaultAbsoluteZoomPositionSpace>"
         "<tt:DefaultRelativePanTiltTranslationSpace>" +
         pt +
         "TranslationGenericSpace</tt:DefaultRelativePanTiltTranslationSpace>"
         "<tt:DefaultRelativeZoomTranslationSpace>" +
         z +
         "TranslationGenericSpace</tt:DefaultRelativeZoomTranslationSpace>"
         "<tt:DefaultContinuousPanTiltVelocitySpace>" +
         pt +
         "VelocityGenericSpace</tt:DefaultContinuousPanTiltVelocitySpace>"
         "<tt:DefaultContinuousZoomVelocitySpace>" +
         z +
         "VelocityGenericSpace</tt:DefaultContinuousZoomVelocitySpace>"
         "<tt:DefaultPTZSpeed><tt:PanTilt x=\"1\" y=\"1\" space=\"" +
         pt + "GenericSpeedSpace\"/><tt:Zoom x=\"1\" space=\"" + z +
         "ZoomGenericSpeedSpace\"/></tt:DefaultPTZSpeed><tt:DefaultPTZTimeout>PT5S</"
         "tt:DefaultPTZTimeout><tt:PanTiltLimits><tt:Range><tt:URI>" +
         pt + "PositionGenericSpace</tt:URI>" + range("XRange", -1, 1) + range("YRange", -1, 1) +
         "</tt:Range></tt:PanTiltLimits><tt:ZoomLimits><tt:Range><tt:URI>" + z +
         "PositionGenericSpace</tt:URI>" + range("XRange", 0, 1) + "</tt:Range></tt:ZoomLimits></" +
         element + ">";
}

std::string ptzVector(const char* element, double x, double y, double z) {
  const std::string pt = std::string(kSpaces) + "PanTiltSpaces/PositionGenericSpace";
  const std::string zs = std::string(kSpaces) + "ZoomSpaces/PositionGenericSpace";
  return std::string("<") + element + "><tt:PanTilt x=\"" + num(x) + "\" y=\"" + num(y) +
         "\" space=\"" + pt + "\"/><tt:Zoom x=\"" + num(z) + "\" space=\"" + zs + "\"/></" +
         element + ">";
}

// xs:duration as ONVIF timeouts use it: PT5S, PT1M30.5S, PT0.5S (days and larger refused).
double parseDuration(const std::string& text) {
  const Fault bad =
      invalidArg("ter:InvalidArgs", "Timeout: not a duration: '" + text.substr(0, 40) + "'");
  if (text.size() < 3 || text.compare(0, 2, "PT") != 0) throw bad;
  double total_s = 0;
  size_t i = 2;
  while (i < text.size()) {
    size_t j = i;
    while (j < text.size() && (std::isdigit(static_cast<unsigned char>(text[j])) || text[j] == '.'))
      ++j;
    if (j == i || j == text.size()) throw bad;
    const double v = parseNumber(text.substr(i, j - i), "Timeout");
    const char unit = text[j];
    total_s += v * (unit == 'H' ? 3600 : unit == 'M' ? 60 : unit == 'S' ? 1 : -1e300);
    if (total_s < 0) throw bad;
    i = j + 1;
  }
  return total_s;
}

}  // namespace

OnvifCameraEmulator::OnvifCameraEmulator(OnvifModel model, OnvifCameraSettings settings,
                                         const PtzPose& home)
    : model_(std::move(model)), settings_(std::move(settings)) {
  motion_.from = motion_.to = normalised(home);
}

OnvifCameraEmulator::Vec3 OnvifCameraEmulator::normalised(const PtzPose& p) const {
  return {model_.panNormalised(p.pan_rad), model_.tiltNormalised(p.tilt_rad),
          model_.zoomNormalised(p.zoom)};
}

PtzPose OnvifCameraEmulator::pose(const Vec3& v) const {
  return {model_.panRad(v[0]), model_.tiltRad(v[1]), model_.zoomRatio(v[2])};
}

OnvifCameraEmulator::Vec3 OnvifCameraEmulator::evaluate(const Motion& m, double host_now_s) const {
  const double dt_s = std::max(0.0, std::min(host_now_s, m.end_s) - m.t0_s);
  Vec3 v;
  for (size_t i = 0; i < 3; ++i) {
    const double d = m.to[i] - m.from[i];
    const double step = m.rate_per_s[i] > 0 ? m.rate_per_s[i] * dt_s : std::abs(d);
    v[i] = m.from[i] + std::clamp(d, -step, step);
  }
  return v;
}

PtzPose OnvifCameraEmulator::setpoint(double host_now_s) const {
  return pose(evaluate(motion_, host_now_s));
}

void OnvifCameraEmulator::moveTo(const Vec3& to, const std::optional<Vec3>& speed,
                                 double host_now_s) {
  Motion m;
  // A new move starts where the setpoint is (a ramp in progress continues from there).
  m.from = evaluate(motion_, host_now_s);
  m.to = {std::clamp(to[0], -1.0, 1.0), std::clamp(to[1], -1.0, 1.0), std::clamp(to[2], 0.0, 1.0)};
  m.t0_s = host_now_s;
  // Without a speed the setpoint jumps (the head's own lag is the motion); with one it ramps at
  // speed x the model's maximum (a speed of 0 would never arrive: the slowest is 1 %).
  if (speed) {
    const double pan_rate =
        model_.pan_tilt_speed_max_rad_s * 2 / (model_.pan_max_rad - model_.pan_min_rad);
    const double tilt_rate =
        model_.pan_tilt_speed_max_rad_s * 2 / (model_.tilt_max_rad - model_.tilt_min_rad);
    m.rate_per_s = {pan_rate * std::clamp(std::abs((*speed)[0]), 0.01, 1.0),
                    tilt_rate * std::clamp(std::abs((*speed)[1]), 0.01, 1.0),
                    std::clamp(std::abs((*speed)[2]), 0.01, 1.0) / kZoomFullRangeS};
  }
  motion_ = m;
}

void OnvifCameraEmulator::checkAuth(const onvif::XmlNode& envelope, double host_now_s) const {
  const onvif::XmlNode token = envelope.find({"Header", "Security", "UsernameToken"});
  if (!token.valid()) throw Fault("env:Sender", "ter:NotAuthorized", "", "Sender not Authorized");
  const std::string user = token.child("Username").text();
  const std::string digest = token.child("Password").text();
  const std::string created = token.child("Created").text();
  const auto nonce = onvif::base64Decode(token.child("Nonce").text());
  const auto created_s = onvif::parseXsDateTime(created);
  const Fault refused("env:Sender", "ter:NotAuthorized", "", "Sender not Authorized");
  if (!nonce || !created_s || user != settings_.user) throw refused;
  if (std::abs(*created_s - cameraNow(host_now_s)) > settings_.created_window_s) throw refused;
  if (onvif::passwordDigest(*nonce, created, settings_.password) != digest) throw refused;
}

OnvifReply OnvifCameraEmulator::handle(std::string_view request, const std::string& xaddr_base,
                                       const PtzPose& now, double host_now_s) {
  OnvifReply r;
  try {
    const onvif::XmlDocument doc = onvif::XmlDocument::parse(request);
    if (!doc.ok())
      throw Fault("env:Sender", "ter:WellFormed", "", "not well formed: " + doc.error());
    const onvif::XmlNode env = doc.root();
    if (env.localName() != "Envelope" || env.namespaceUri() != kSoapNs) {
      throw Fault("env:VersionMismatch", "", "", "not a SOAP 1.2 envelope");
    }
    const std::vector<onvif::XmlNode> ops = env.child("Body").children();
    if (ops.empty()) throw invalidArg("ter:InvalidArgs", "an empty Body");
    const onvif::XmlNode& op = ops.front();
    // GetSystemDateAndTime is open to all: a client needs the camera's clock to sign.
    const bool open = op.localName() == "GetSystemDateAndTime" && op.namespaceUri() == kDeviceNs;
    if (!settings_.password.empty() && !open) checkAuth(env, host_now_s);
    r.body = envelope(dispatch(op, xaddr_base, now, host_now_s, &r.delay_s));
  } catch (const Fault& f) {
    ++faults_;
    if (f.subcode == "ter:NotAuthorized") ++auth_refused_;
    r.http_status = f.code == "env:Receiver" ? 500 : 400;
    r.body = envelope(faultBody(f));
    r.delay_s = 0;
  }
  return r;
}

std::string OnvifCameraEmulator::dispatch(const onvif::XmlNode& op, const std::string& xaddr,
                                          const PtzPose& now, double host_now_s, double* delay_s) {
  const std::string name(op.localName());
  const std::string_view ns = op.namespaceUri();
  const std::string res = name + "Response";
  const auto profile = [&op] {
    const std::string token = op.child("ProfileToken").text();
    if (token != kProfile) throw invalidArg("ter:NoProfile", "no profile '" + token + "'");
  };
  const auto vec = [&op](const char* element, bool need) -> std::optional<Vec3> {
    const onvif::XmlNode v = op.child(element);
    if (!v.valid()) {
      if (need) throw invalidArg("ter:InvalidArgs", std::string("no ") + element);
      return std::nullopt;
    }
    const onvif::XmlNode pt = v.child("PanTilt"), z = v.child("Zoom");
    if (!pt.valid() && !z.valid()) {
      throw invalidArg("ter:InvalidArgs", std::string(element) + " without PanTilt or Zoom");
    }
    // An absent axis: NaN, "leave it" (the caller fills it).
    const double nan = std::nan("");
    return Vec3{attributeNumber(pt, "x", element).value_or(nan),
                attributeNumber(pt, "y", element).value_or(nan),
                attributeNumber(z, "x", element).value_or(nan)};
  };
  const Vec3 at = evaluate(motion_, host_now_s);  // the setpoint now
  const auto fill = [](Vec3 v, const Vec3& with) {
    for (size_t i = 0; i < 3; ++i) {
      if (std::isnan(v[i])) v[i] = with[i];
    }
    return v;
  };

  if (ns == kDeviceNs) {
    if (name == "GetSystemDateAndTime") {
      const double t_s = cameraNow(host_now_s);
      const std::time_t whole = static_cast<std::time_t>(std::floor(t_s));
      std::tm u{};
      gmtime_r(&whole, &u);
      return "<tds:GetSystemDateAndTimeResponse><tds:SystemDateAndTime>"
             "<tt:DateTimeType>Manual</tt:DateTimeType><tt:DaylightSavings>false</"
             "tt:DaylightSavings><tt:TimeZone><tt:TZ>UTC0</tt:TZ></tt:TimeZone><tt:UTCDateTime>"
             "<tt:Time><tt:Hour>" +
             std::to_string(u.tm_hour) + "</tt:Hour><tt:Minute>" + std::to_string(u.tm_min) +
             "</tt:Minute><tt:Second>" + std::to_string(u.tm_sec) +
             "</tt:Second></tt:Time><tt:Date><tt:Year>" + std::to_string(u.tm_year + 1900) +
             "</tt:Year><tt:Month>" + std::to_string(u.tm_mon + 1) + "</tt:Month><tt:Day>" +
             std::to_string(u.tm_mday) +
             "</tt:Day></tt:Date></tt:UTCDateTime></tds:SystemDateAndTime>"
             "</tds:GetSystemDateAndTimeResponse>";
    }
    if (name == "GetCapabilities") {
      return "<tds:GetCapabilitiesResponse><tds:Capabilities><tt:Device><tt:XAddr>" + xaddr +
             "/onvif/device_service</tt:XAddr></tt:Device><tt:Media><tt:XAddr>" + xaddr +
             "/onvif/media_service</tt:XAddr><tt:StreamingCapabilities><tt:RTPMulticast>false</"
             "tt:RTPMulticast><tt:RTP_TCP>true</tt:RTP_TCP><tt:RTP_RTSP_TCP>true</"
             "tt:RTP_RTSP_TCP></tt:StreamingCapabilities></tt:Media><tt:PTZ><tt:XAddr>" +
             xaddr + "/onvif/ptz_service</tt:XAddr></tt:PTZ></tds:Capabilities>" +
             "</tds:GetCapabilitiesResponse>";
    }
    if (name == "GetServices") {
      const auto service = [&xaddr](const char* ns_uri, const char* path, int major, int minor) {
        return std::string("<tds:Service><tds:Namespace>") + ns_uri +
               "</tds:Namespace><tds:XAddr>" + xaddr + path +
               "</tds:XAddr><tds:Version><tt:Major>" + std::to_string(major) +
               "</tt:Major><tt:Minor>" + std::to_string(minor) +
               "</tt:Minor></tds:Version></tds:Service>";
      };
      return "<tds:GetServicesResponse>" + service(kDeviceNs, "/onvif/device_service", 2, 60) +
             service(kMediaNs, "/onvif/media_service", 2, 60) +
             service(kPtzNs, "/onvif/ptz_service", 2, 60) + "</tds:GetServicesResponse>";
    }
    if (name == "GetDeviceInformation") {
      return "<tds:GetDeviceInformationResponse><tds:Manufacturer>" +
             onvif::xmlEscape(model_.manufacturer) + "</tds:Manufacturer><tds:Model>" +
             onvif::xmlEscape(model_.model) +
             "</tds:Model><tds:FirmwareVersion>ptz-sim</tds:FirmwareVersion><tds:SerialNumber>" +
             onvif::xmlEscape(settings_.serial) + "</tds:SerialNumber><tds:HardwareId>" +
             onvif::xmlEscape(model_.name) + "</tds:HardwareId></tds:GetDeviceInformationResponse>";
    }
  } else if (ns == kMediaNs) {
    if (name == "GetProfiles" || name == "GetProfile") {
      const char* element = name == "GetProfiles" ? "trt:Profiles" : "trt:Profile";
      if (name == "GetProfile") profile();
      return "<trt:" + res + "><" + element + " token=\"" + kProfile +
             "\" fixed=\"true\"><tt:Name>" + kProfile +
             "</tt:Name><tt:VideoSourceConfiguration token=\"video_source_config_1\">"
             "<tt:Name>video source</tt:Name><tt:UseCount>1</tt:UseCount>"
             "<tt:SourceToken>video_source_1</tt:SourceToken>"
             "<tt:Bounds x=\"0\" y=\"0\" width=\"640\" height=\"480\"/>"
             "</tt:VideoSourceConfiguration>"
             "<tt:VideoEncoderConfiguration token=\"video_encoder_1\"><tt:Name>H.264 VGA</tt:Name>"
             "<tt:UseCount>1</tt:UseCount><tt:Encoding>H264</tt:Encoding><tt:Resolution>"
             "<tt:Width>640</tt:Width><tt:Height>480</tt:Height></tt:Resolution>"
             "<tt:Quality>5</tt:Quality><tt:RateControl><tt:FrameRateLimit>30</tt:FrameRateLimit>"
             "<tt:EncodingInterval>1</tt:EncodingInterval><tt:BitrateLimit>2048</tt:BitrateLimit>"
             "</tt:RateControl><tt:H264><tt:GovLength>30</tt:GovLength>"
             "<tt:H264Profile>Main</tt:H264Profile></tt:H264><tt:Multicast><tt:Address>"
             "<tt:Type>IPv4</tt:Type><tt:IPv4Address>0.0.0.0</tt:IPv4Address></tt:Address>"
             "<tt:Port>0</tt:Port><tt:TTL>1</tt:TTL><tt:AutoStart>false</tt:AutoStart>"
             "</tt:Multicast><tt:SessionTimeout>PT60S</tt:SessionTimeout>"
             "</tt:VideoEncoderConfiguration>" +
             ptzConfiguration("tt:PTZConfiguration") + "</" + element + "></trt:" + res + ">";
    }
    if (name == "GetVideoSources") {
      return "<trt:GetVideoSourcesResponse><trt:VideoSources token=\"video_source_1\">"
             "<tt:Framerate>30</tt:Framerate><tt:Resolution><tt:Width>640</tt:Width>"
             "<tt:Height>480</tt:Height></tt:Resolution></trt:VideoSources>"
             "</trt:GetVideoSourcesResponse>";
    }
    if (name == "GetStreamUri") {
      profile();
      // rtsp:// on the host the client reached, the port RTSP's.
      std::string host = xaddr.substr(xaddr.find("//") + 2);
      host = host.substr(0, host.rfind(':'));
      return "<trt:GetStreamUriResponse><trt:MediaUri><tt:Uri>rtsp://" + host +
             ":554/profile_1</tt:Uri><tt:InvalidAfterConnect>false</tt:InvalidAfterConnect>"
             "<tt:InvalidAfterReboot>false</tt:InvalidAfterReboot><tt:Timeout>PT60S</tt:Timeout>"
             "</trt:MediaUri></trt:GetStreamUriResponse>";
    }
  } else if (ns == kPtzNs) {
    const std::string node = std::string("token=\"") + kNode +
                             "\" FixedHomePosition=\"false\"><tt:Name>PTZ</tt:Name>"
                             "<tt:SupportedPTZSpaces>" +
                             ptzSpaces(model_.absolute_moves) +
                             "</tt:SupportedPTZSpaces><tt:MaximumNumberOfPresets>100</"
                             "tt:MaximumNumberOfPresets><tt:HomeSupported>false</tt:HomeSupported>";
    if (name == "GetNodes") {
      return "<tptz:GetNodesResponse><tptz:PTZNode " + node +
             "</tptz:PTZNode></tptz:GetNodesResponse>";
    }
    if (name == "GetNode") {
      const std::string token = op.child("NodeToken").text();
      if (token != kNode) throw invalidArg("ter:NoEntity", "no PTZ node '" + token + "'");
      return "<tptz:GetNodeResponse><tptz:PTZNode " + node +
             "</tptz:PTZNode></tptz:GetNodeResponse>";
    }
    if (name == "GetConfigurations") {
      return "<tptz:GetConfigurationsResponse>" + ptzConfiguration("tptz:PTZConfiguration") +
             "</tptz:GetConfigurationsResponse>";
    }
    if (name == "GetConfiguration") {
      const std::string token = op.child("PTZConfigurationToken").text();
      if (token != kPtzConfig) throw invalidArg("ter:NoConfig", "no configuration '" + token + "'");
      return "<tptz:GetConfigurationResponse>" + ptzConfiguration("tptz:PTZConfiguration") +
             "</tptz:GetConfigurationResponse>";
    }
    if (name == "GetConfigurationOptions") {
      const std::string token = op.child("ConfigurationToken").text();
      if (token != kPtzConfig) throw invalidArg("ter:NoConfig", "no configuration '" + token + "'");
      return "<tptz:GetConfigurationOptionsResponse><tptz:PTZConfigurationOptions><tt:Spaces>" +
             ptzSpaces(model_.absolute_moves) +
             "</tt:Spaces><tt:PTZTimeout><tt:Min>PT1S</tt:Min><tt:Max>PT60S</tt:Max>"
             "</tt:PTZTimeout></tptz:PTZConfigurationOptions>"
             "</tptz:GetConfigurationOptionsResponse>";
    }
    if (name == "GetStatus") {
      profile();
      const Vec3 pos = normalised(now);
      const Vec3 goal = motion_.to;
      const bool pt_moving = std::abs(pos[0] - goal[0]) > kIdleTolerance ||
                             std::abs(pos[1] - goal[1]) > kIdleTolerance ||
                             (host_now_s < motion_.end_s && motion_.end_s < 1e300);
      const bool zoom_moving = std::abs(pos[2] - goal[2]) > kIdleTolerance;
      *delay_s = model_.cheap ? model_.status_delay_ms / 1000 : 0;
      return "<tptz:GetStatusResponse><tptz:PTZStatus>" +
             ptzVector("tt:Position", pos[0], pos[1], pos[2]) + "<tt:MoveStatus><tt:PanTilt>" +
             (pt_moving ? "MOVING" : "IDLE") + "</tt:PanTilt><tt:Zoom>" +
             (zoom_moving ? "MOVING" : "IDLE") + "</tt:Zoom></tt:MoveStatus><tt:UtcTime>" +
             onvif::xsDateTime(cameraNow(host_now_s)) +
             "</tt:UtcTime></tptz:PTZStatus></tptz:GetStatusResponse>";
    }
    if (name == "AbsoluteMove") {
      profile();
      if (!model_.absolute_moves) {
        throw invalidArg("ter:ActionNotSupported", "this camera has no AbsoluteMove");
      }
      const Vec3 to = fill(*vec("Position", true), at);
      if (std::abs(to[0]) > 1 || std::abs(to[1]) > 1 || to[2] < 0 || to[2] > 1) {
        throw invalidArg("ter:InvalidPosition", "Position outside the generic space");
      }
      auto speed = vec("Speed", false);
      if (speed) speed = fill(*speed, {1, 1, 1});
      // A cheap camera ignores the Speed: the head moves at its own pace.
      moveTo(to, model_.cheap ? std::nullopt : speed, host_now_s);
      return "<tptz:AbsoluteMoveResponse/>";
    }
    if (name == "RelativeMove") {
      profile();
      const Vec3 d = fill(*vec("Translation", true), {0, 0, 0});
      const Vec3 pos = normalised(now);
      auto speed = vec("Speed", false);
      if (speed) speed = fill(*speed, {1, 1, 1});
      moveTo({pos[0] + d[0], pos[1] + d[1], pos[2] + d[2]}, speed, host_now_s);
      return "<tptz:RelativeMoveResponse/>";
    }
    if (name == "ContinuousMove") {
      profile();
      const Vec3 v = fill(*vec("Velocity", true), {0, 0, 0});
      for (double c : v) {
        if (std::abs(c) > 1) throw invalidArg("ter:InvalidVelocity", "Velocity beyond 1");
      }
      const onvif::XmlNode timeout = op.child("Timeout");
      const double timeout_s = timeout.valid() ? parseDuration(timeout.text()) : 5.0;
      // Towards the end of each axis at |v| x the maximum speed, until Stop or the timeout.
      moveTo({v[0] > 0   ? 1
              : v[0] < 0 ? -1
                         : at[0],
              v[1] > 0   ? 1
              : v[1] < 0 ? -1
                         : at[1],
              v[2] > 0   ? 1
              : v[2] < 0 ? 0
                         : at[2]},
             v, host_now_s);
      motion_.end_s = host_now_s + timeout_s;
      return "<tptz:ContinuousMoveResponse/>";
    }
    if (name == "Stop") {
      profile();
      const std::string pt = op.child("PanTilt").text(), z = op.child("Zoom").text();
      const bool stop_pt = pt != "false", stop_z = z != "false";
      // Hold where the head is now on the axes stopped.
      const Vec3 pos = normalised(now);
      moveTo({stop_pt ? pos[0] : at[0], stop_pt ? pos[1] : at[1], stop_z ? pos[2] : at[2]},
             std::nullopt, host_now_s);
      return "<tptz:StopResponse/>";
    }
    if (name == "GetPresets") {
      profile();
      std::string out = "<tptz:GetPresetsResponse>";
      for (const auto& [token, p] : presets_) {
        out += "<tptz:Preset token=\"" + onvif::xmlEscape(token) + "\"><tt:Name>" +
               onvif::xmlEscape(p.name) + "</tt:Name>" +
               ptzVector("tt:PTZPosition", p.position[0], p.position[1], p.position[2]) +
               "</tptz:Preset>";
      }
      return out + "</tptz:GetPresetsResponse>";
    }
    if (name == "SetPreset") {
      profile();
      std::string token = op.child("PresetToken").text();
      std::string preset_name = op.child("PresetName").text();
      if (preset_name.size() > 64) throw invalidArg("ter:InvalidPresetName", "name too long");
      if (!token.empty() && !presets_.count(token)) {
        throw invalidArg("ter:NoToken", "no preset '" + token + "'");
      }
      if (token.empty()) {
        if (presets_.size() >= 100) {
          throw Fault("env:Receiver", "ter:Action", "ter:TooManyPresets", "100 presets set");
        }
        token = "preset_" + std::to_string(next_preset_++);
      }
      if (preset_name.empty()) preset_name = token;
      presets_[token] = {preset_name, normalised(now)};
      return "<tptz:SetPresetResponse><tptz:PresetToken>" + onvif::xmlEscape(token) +
             "</tptz:PresetToken></tptz:SetPresetResponse>";
    }
    if (name == "GotoPreset" || name == "RemovePreset") {
      profile();
      const std::string token = op.child("PresetToken").text();
      const auto it = presets_.find(token);
      if (it == presets_.end()) throw invalidArg("ter:NoToken", "no preset '" + token + "'");
      if (name == "RemovePreset") {
        presets_.erase(it);
        return "<tptz:RemovePresetResponse/>";
      }
      auto speed = vec("Speed", false);
      if (speed) speed = fill(*speed, {1, 1, 1});
      moveTo(it->second.position, speed, host_now_s);
      return "<tptz:GotoPresetResponse/>";
    }
  }
  throw Fault("env:Receiver", "ter:ActionNotSupported", "",
              "operation not supported: " + name + " (" + std::string(ns) + ")");
}

}  // namespace ptz::driver
