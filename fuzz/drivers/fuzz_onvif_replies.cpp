// What ptz-driver's ONVIF client reads from a camera: the input as the body of every reply
// (device, media, PTZ, WS-Discovery's ProbeMatches; openReply's fault path) and as the text of the
// number and duration readers. Properties: only a Result comes back (nothing throws); a refusal
// says why in at most 4 kB; accepted values are within what the parsers promise (finite numbers in
// range, tokens and names short, URLs of their scheme, Min <= Max); a number read back from its
// printed form is the same double.
#include <cmath>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.hpp"
#include "ptz_driver/heads/onvif/device_replies.hpp"
#include "ptz_driver/heads/onvif/ptz_replies.hpp"

namespace onvif = ptz::onvif;

namespace {

template <typename T>
bool accepted(const onvif::Result<T>& r) {
  if (r) return true;
  FUZZ_CHECK(!r.error().empty() && r.error().size() <= 4096,
             "an error of " + std::to_string(r.error().size()) + " bytes");
  return false;
}

void checkValue(std::optional<double> v, double max_abs, const char* what) {
  if (v) FUZZ_CHECK(std::isfinite(*v) && std::fabs(*v) <= max_abs, what);
}

void checkText(const std::string& s, std::size_t max_chars, const char* what) {
  FUZZ_CHECK(s.size() <= max_chars, std::string(what) + " of " + std::to_string(s.size()));
  for (char c : s) FUZZ_CHECK(static_cast<unsigned char>(c) >= 0x20 && c != 0x7f, what);
}

void checkUrl(const std::string& s, const char* what) {
  if (s.empty()) return;
  checkText(s, onvif::kMaxUrlChars, what);
  FUZZ_CHECK(s.rfind("http://", 0) == 0 || s.rfind("https://", 0) == 0, what);
}

void checkSpace(const std::optional<onvif::Space>& s) {
  if (!s) return;
  checkUrl(s->uri, "space URI");
  for (const onvif::Range& r : {s->x, s->y}) {
    checkValue(r.min, onvif::kMaxSpaceValue, "range min");
    checkValue(r.max, onvif::kMaxSpaceValue, "range max");
    FUZZ_CHECK(r.min <= r.max, "range min above max");
  }
}

void checkSpaces(const onvif::PtzSpaces& s) {
  for (const auto* space : {&s.absolute_pan_tilt, &s.absolute_zoom, &s.relative_pan_tilt,
                            &s.relative_zoom, &s.continuous_pan_tilt_velocity,
                            &s.continuous_zoom_velocity, &s.pan_tilt_speed, &s.zoom_speed}) {
    checkSpace(*space);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);

  if (const auto t = onvif::parseSystemDateAndTime(in); accepted(t)) {
    FUZZ_CHECK(*t >= 0 && *t < 7.3e9, "camera time " + std::to_string(*t));
  }
  for (const auto& a : {onvif::parseCapabilities(in), onvif::parseServices(in)}) {
    if (!accepted(a)) continue;
    checkUrl(a->device_url, "device URL");
    checkUrl(a->media_url, "media URL");
    checkUrl(a->ptz_url, "PTZ URL");
    FUZZ_CHECK(!a->media_url.empty() || !a->ptz_url.empty(), "neither media nor PTZ");
  }
  if (const auto p = onvif::parseProfiles(in); accepted(p)) {
    FUZZ_CHECK(!p->empty() && p->size() <= onvif::kMaxProfiles, "profile count");
    for (const onvif::MediaProfile& m : *p) {
      FUZZ_CHECK(!m.token.empty(), "empty profile token");
      checkText(m.token, onvif::kMaxTokenChars, "profile token");
      checkText(m.name, onvif::kMaxNameChars, "profile name");
      checkText(m.ptz_configuration_token, onvif::kMaxTokenChars, "PTZ configuration token");
      FUZZ_CHECK(m.video_width_px >= 0 && m.video_width_px <= 16384 && m.video_height_px >= 0 &&
                     m.video_height_px <= 16384,
                 "resolution");
    }
  }
  if (const auto u = onvif::parseStreamUri(in); accepted(u)) {
    FUZZ_CHECK(u->rfind("rtsp://", 0) == 0 || u->rfind("rtsps://", 0) == 0, "stream URI scheme");
    checkText(*u, onvif::kMaxUrlChars, "stream URI");
  }
  if (const auto n = onvif::parseNodes(in); accepted(n)) {
    FUZZ_CHECK(!n->empty() && n->size() <= onvif::kMaxNodes, "node count");
    for (const onvif::PtzNode& node : *n) {
      checkText(node.token, onvif::kMaxTokenChars, "node token");
      checkSpaces(node.spaces);
      FUZZ_CHECK(node.max_presets >= 0 && node.max_presets <= 100000, "max presets");
    }
  }
  if (const auto o = onvif::parseConfigurationOptions(in); accepted(o)) {
    checkSpaces(o->spaces);
    if (o->timeout_s) {
      FUZZ_CHECK(o->timeout_s->min >= 0 && o->timeout_s->min <= o->timeout_s->max &&
                     o->timeout_s->max <= 1e9,
                 "timeout range");
    }
  }
  if (const auto s = onvif::parseStatus(in); accepted(s)) {
    checkValue(s->pan, onvif::kMaxSpaceValue, "status pan");
    checkValue(s->tilt, onvif::kMaxSpaceValue, "status tilt");
    checkValue(s->zoom, onvif::kMaxSpaceValue, "status zoom");
    checkValue(s->camera_utc_s, 1e12, "status time");
  }
  if (const auto p = onvif::parsePresets(in); accepted(p)) {
    FUZZ_CHECK(p->size() <= onvif::kMaxPresets, "preset count");
    for (const onvif::Preset& preset : *p) {
      FUZZ_CHECK(!preset.token.empty(), "empty preset token");
      checkText(preset.token, onvif::kMaxTokenChars, "preset token");
      checkText(preset.name, onvif::kMaxNameChars, "preset name");
      checkValue(preset.pan, onvif::kMaxSpaceValue, "preset pan");
      checkValue(preset.tilt, onvif::kMaxSpaceValue, "preset tilt");
      checkValue(preset.zoom, onvif::kMaxSpaceValue, "preset zoom");
    }
  }
  if (const auto t = onvif::parseSetPreset(in); accepted(t)) {
    FUZZ_CHECK(!t->empty(), "empty preset token");
    checkText(*t, onvif::kMaxTokenChars, "preset token");
  }
  if (const auto m = onvif::parseProbeMatches(in, ""); accepted(m)) {
    FUZZ_CHECK(m->size() <= onvif::kMaxListItems, "match count");
    for (const onvif::ProbeMatch& match : *m) {
      FUZZ_CHECK(!match.xaddrs.empty() && match.xaddrs.size() <= onvif::kMaxListItems &&
                     match.scopes.size() <= onvif::kMaxListItems,
                 "list sizes");
      for (const std::string& x : match.xaddrs) checkUrl(x, "XAddr");
      for (const std::string& scope : match.scopes) {
        FUZZ_CHECK(!scope.empty() && scope.find(' ') == std::string::npos, "scope");
        checkText(scope, onvif::kMaxNameChars, "scope");
      }
    }
  }
  const auto fault = onvif::openReply(in, "StopResponse", onvif::kPtzNs);
  if (!accepted(fault) && fault.fault()) {
    FUZZ_CHECK(fault.fault()->code.size() <= 259 && fault.fault()->subcode.size() <= 259 &&
                   fault.fault()->reason.size() <= 259,
               "fault texts not clipped");
  }

  // The readers on the raw text (short inputs only: they are for one attribute's value).
  if (size <= 64) {
    if (const auto v = onvif::readDouble(in, "v"); accepted(v)) {
      FUZZ_CHECK(std::isfinite(*v) && std::fabs(*v) <= 1e9, "number");
      const auto again = onvif::readDouble(onvif::formatNumber(*v), "v");
      FUZZ_CHECK(again && *again == *v, "number does not read back: " + std::string(in));
    }
    if (const auto d = onvif::readDurationS(in, "d"); accepted(d)) {
      FUZZ_CHECK(*d >= 0 && *d <= 1e9, "duration " + std::to_string(*d));
    }
  }
  return 0;
}
