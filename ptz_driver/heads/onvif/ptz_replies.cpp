#include "ptz_driver/heads/onvif/ptz_replies.hpp"

#include "ptz_driver/heads/onvif/device_replies.hpp"

namespace ptz::onvif {
namespace {

Error missing(const std::string& field) {
  return {field + ": missing", std::nullopt};
}

Result<double> number(std::optional<std::string> text, const std::string& field) {
  if (!text) return missing(field);
  return readDouble(*text, field, kMaxSpaceValue);
}

std::optional<std::string> childText(const XmlNode& node, std::string_view name) {
  const XmlNode c = node.child(name);
  if (!c.valid()) return std::nullopt;
  return c.text();
}

Result<Range> range(const XmlNode& node, const std::string& field) {
  if (!node.valid()) return missing(field);
  const Result<double> min = number(childText(node, "Min"), field + "/Min");
  if (!min) return min.fullError();
  const Result<double> max = number(childText(node, "Max"), field + "/Max");
  if (!max) return max.fullError();
  if (*min > *max) {
    return Error{field + ": Min " + formatNumber(*min) + " above Max " + formatNumber(*max),
                 std::nullopt};
  }
  return Range{*min, *max};
}

// The first element `kind` of `spaces`: URI, XRange and (2-D) YRange.
Result<std::optional<Space>> space(const XmlNode& spaces, const char* kind, bool two_d) {
  const XmlNode node = spaces.child(kind);
  if (!node.valid()) return std::optional<Space>();
  const std::string field = kind;
  Space s;
  const Result<std::string> uri =
      readUrl(node.child("URI").text(), field + "/URI", {"http://", "https://"});
  if (!uri) return uri.fullError();
  s.uri = *uri;
  const Result<Range> x = range(node.child("XRange"), field + "/XRange");
  if (!x) return x.fullError();
  s.x = *x;
  if (two_d) {
    const Result<Range> y = range(node.child("YRange"), field + "/YRange");
    if (!y) return y.fullError();
    s.y = *y;
  }
  return std::optional<Space>(s);
}

Result<PtzSpaces> spaces(const XmlNode& node, const std::string& field) {
  if (!node.valid()) return missing(field);
  PtzSpaces s;
  struct Kind {
    const char* name;
    bool two_d;
    std::optional<Space>* out;
  };
  const Kind kinds[] = {
      {"AbsolutePanTiltPositionSpace", true, &s.absolute_pan_tilt},
      {"AbsoluteZoomPositionSpace", false, &s.absolute_zoom},
      {"RelativePanTiltTranslationSpace", true, &s.relative_pan_tilt},
      {"RelativeZoomTranslationSpace", false, &s.relative_zoom},
      {"ContinuousPanTiltVelocitySpace", true, &s.continuous_pan_tilt_velocity},
      {"ContinuousZoomVelocitySpace", false, &s.continuous_zoom_velocity},
      // onvif.xsd: speed spaces have an XRange only, for pan and tilt together.
      {"PanTiltSpeedSpace", false, &s.pan_tilt_speed},
      {"ZoomSpeedSpace", false, &s.zoom_speed},
  };
  for (const Kind& k : kinds) {
    Result<std::optional<Space>> one = space(node, k.name, k.two_d);
    if (!one) return one.fullError();
    *k.out = *one;
  }
  return s;
}

Result<std::string> token(const XmlNode& node, const std::string& field) {
  return readText(node.attribute("token").value_or(""), field + "@token", kMaxTokenChars);
}

// A tt:PTZVector's PanTilt x, y and Zoom x, each when present.
Result<bool> position(const XmlNode& node, const std::string& field, std::optional<double>* pan,
                      std::optional<double>* tilt, std::optional<double>* zoom) {
  const XmlNode pt = node.child("PanTilt");
  if (pt.valid()) {
    const Result<double> x = number(pt.attribute("x"), field + "/PanTilt@x");
    if (!x) return x.fullError();
    const Result<double> y = number(pt.attribute("y"), field + "/PanTilt@y");
    if (!y) return y.fullError();
    *pan = *x;
    *tilt = *y;
  }
  const XmlNode z = node.child("Zoom");
  if (z.valid()) {
    const Result<double> x = number(z.attribute("x"), field + "/Zoom@x");
    if (!x) return x.fullError();
    *zoom = *x;
  }
  return true;
}

Result<MoveState> moveState(const XmlNode& node, const std::string& field) {
  if (!node.valid()) return MoveState::kUnknown;
  const std::string text = node.text();
  if (text == "IDLE") return MoveState::kIdle;
  if (text == "MOVING") return MoveState::kMoving;
  if (text == "UNKNOWN") return MoveState::kUnknown;
  return Error{field + " '" + text.substr(0, 64) + "': not IDLE, MOVING or UNKNOWN", std::nullopt};
}

}  // namespace

Result<std::vector<PtzNode>> parseNodes(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetNodesResponse", kPtzNs);
  if (!r) return r.fullError();
  const std::vector<XmlNode> nodes = r->response.children("PTZNode");
  if (nodes.empty()) return Error{"PTZNode: none", std::nullopt};
  if (nodes.size() > kMaxNodes) {
    return Error{"PTZNode: " + std::to_string(nodes.size()) + " nodes (at most " +
                     std::to_string(kMaxNodes) + ")",
                 std::nullopt};
  }
  std::vector<PtzNode> out;
  for (const XmlNode& n : nodes) {
    PtzNode node;
    const Result<std::string> t = token(n, "PTZNode");
    if (!t) return t.fullError();
    node.token = *t;
    const std::string where = "PTZNode '" + node.token + "' ";
    const Result<std::string> name =
        readText(n.child("Name").text(), where + "Name", kMaxNameChars, 0);
    if (!name) return name.fullError();
    node.name = *name;
    const Result<PtzSpaces> s = spaces(n.child("SupportedPTZSpaces"), where + "SupportedPTZSpaces");
    if (!s) return s.fullError();
    node.spaces = *s;
    const XmlNode presets = n.child("MaximumNumberOfPresets");
    if (!presets.valid()) return missing(where + "MaximumNumberOfPresets");
    const Result<long long> max_presets =
        readInteger(presets.text(), where + "MaximumNumberOfPresets", 0, 100000);
    if (!max_presets) return max_presets.fullError();
    node.max_presets = static_cast<int>(*max_presets);
    const XmlNode home = n.child("HomeSupported");
    if (!home.valid()) return missing(where + "HomeSupported");
    const Result<bool> home_supported = readBool(home.text(), where + "HomeSupported");
    if (!home_supported) return home_supported.fullError();
    node.home_supported = *home_supported;
    out.push_back(std::move(node));
  }
  return out;
}

Result<PtzConfigurationOptions> parseConfigurationOptions(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetConfigurationOptionsResponse", kPtzNs);
  if (!r) return r.fullError();
  const XmlNode options = r->response.child("PTZConfigurationOptions");
  if (!options.valid()) return missing("PTZConfigurationOptions");
  PtzConfigurationOptions o;
  const Result<PtzSpaces> s = spaces(options.child("Spaces"), "PTZConfigurationOptions/Spaces");
  if (!s) return s.fullError();
  o.spaces = *s;
  const XmlNode timeout = options.child("PTZTimeout");
  if (timeout.valid()) {
    const Result<double> min = readDurationS(timeout.child("Min").text(), "PTZTimeout/Min");
    if (!min) return min.fullError();
    const Result<double> max = readDurationS(timeout.child("Max").text(), "PTZTimeout/Max");
    if (!max) return max.fullError();
    if (*min > *max) return Error{"PTZTimeout: Min above Max", std::nullopt};
    o.timeout_s = Range{*min, *max};
  }
  return o;
}

Result<PtzStatus> parseStatus(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetStatusResponse", kPtzNs);
  if (!r) return r.fullError();
  const XmlNode status = r->response.child("PTZStatus");
  if (!status.valid()) return missing("PTZStatus");
  PtzStatus s;
  const XmlNode pos = status.child("Position");
  if (pos.valid()) {
    const Result<bool> p = position(pos, "PTZStatus/Position", &s.pan, &s.tilt, &s.zoom);
    if (!p) return p.fullError();
  }
  const Result<MoveState> pt =
      moveState(status.find({"MoveStatus", "PanTilt"}), "MoveStatus/PanTilt");
  if (!pt) return pt.fullError();
  s.pan_tilt_move = *pt;
  const Result<MoveState> z = moveState(status.find({"MoveStatus", "Zoom"}), "MoveStatus/Zoom");
  if (!z) return z.fullError();
  s.zoom_move = *z;
  const XmlNode utc = status.child("UtcTime");
  if (utc.valid()) {
    const std::string text = utc.text();
    const std::optional<double> t = parseXsDateTime(text);
    if (!t) {
      return Error{"PTZStatus/UtcTime '" + text.substr(0, 64) + "': not an xs:dateTime",
                   std::nullopt};
    }
    s.camera_utc_s = *t;
  }
  return s;
}

Result<std::vector<Preset>> parsePresets(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "GetPresetsResponse", kPtzNs);
  if (!r) return r.fullError();
  const std::vector<XmlNode> nodes = r->response.children("Preset");
  if (nodes.size() > kMaxPresets) {
    return Error{"Preset: " + std::to_string(nodes.size()) + " presets (at most " +
                     std::to_string(kMaxPresets) + ")",
                 std::nullopt};
  }
  std::vector<Preset> out;
  for (const XmlNode& n : nodes) {
    Preset p;
    const Result<std::string> t = token(n, "Preset");
    if (!t) return t.fullError();
    p.token = *t;
    const std::string where = "Preset '" + p.token + "' ";
    const Result<std::string> name =
        readText(n.child("Name").text(), where + "Name", kMaxNameChars, 0);
    if (!name) return name.fullError();
    p.name = *name;
    const XmlNode pos = n.child("PTZPosition");
    if (pos.valid()) {
      const Result<bool> ok = position(pos, where + "PTZPosition", &p.pan, &p.tilt, &p.zoom);
      if (!ok) return ok.fullError();
    }
    out.push_back(std::move(p));
  }
  return out;
}

Result<std::string> parseSetPreset(std::string_view reply) {
  const Result<SoapReply> r = openReply(reply, "SetPresetResponse", kPtzNs);
  if (!r) return r.fullError();
  const XmlNode t = r->response.child("PresetToken");
  if (!t.valid()) return missing("SetPresetResponse/PresetToken");
  return readText(t.text(), "SetPresetResponse/PresetToken", kMaxTokenChars);
}

Result<bool> parseEmptyPtzReply(std::string_view reply, std::string_view response_name) {
  const Result<SoapReply> r = openReply(reply, response_name, kPtzNs);
  if (!r) return r.fullError();
  return true;
}

}  // namespace ptz::onvif
