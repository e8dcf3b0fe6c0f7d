#include "ptz_driver/heads/onvif/head/onvif_session.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "ptz_driver/heads/onvif/device_replies.hpp"

namespace ptz::driver {
namespace {

constexpr double kDeadbandRad = 1e-3;  // continuous mode: closer than this, the axis rests
constexpr double kDeadbandZoom = 1e-3;
constexpr double kBestSampleAgeS = 30;  // the fastest GetStatus of the last this many seconds

bool near(const onvif::Range& r, double min, double max) {
  return std::abs(r.min - min) < 1e-6 && std::abs(r.max - max) < 1e-6;
}

std::string deviceUrl(const std::string& url) {
  // "http://host:port" names the camera; a full service URL is taken as it is.
  if (url.find("/onvif/") != std::string::npos) return url;
  return (!url.empty() && url.back() == '/' ? url.substr(0, url.size() - 1) : url) +
         "/onvif/device_service";
}

}  // namespace

OnvifSession::OnvifSession(OnvifModel model, OnvifHeadSettings settings,
                           std::function<double()> now_s)
    : model_(std::move(model)), settings_(std::move(settings)), now_s_(std::move(now_s)) {
  const long timeout_ms = std::max(1L, std::lround(settings_.timeout_ms));
  http_options_.connect_timeout_ms = timeout_ms;
  http_options_.total_timeout_ms = timeout_ms;
  http_options_.http_user = settings_.user;
  http_options_.http_password = settings_.password;
}

OnvifOutcome OnvifSession::post(const std::string& url, const onvif::Request& r, std::string* body,
                                double* sent_s, double* received_s) {
  const std::string op = r.action.substr(r.action.rfind('/') + 1);
  const double t0 = now_s_();
  std::optional<onvif::UsernameToken> token;
  if (!settings_.password.empty()) {
    token = onvif::makeUsernameToken(settings_.user, settings_.password, t0 + offset_s_);
  }
  ++requests_;
  auto reply = http_.post(url, r.action, onvif::envelope(r.body, token), http_options_);
  if (sent_s) *sent_s = t0;
  if (received_s) *received_s = now_s_();
  if (!reply) {
    const bool timeout = reply.error().rfind("timeout", 0) == 0;
    return {timeout ? OnvifFailure::kTimeout : OnvifFailure::kTransport, op + ": " + reply.error()};
  }
  last_http_status_ = reply->status;
  *body = reply->body;
  return {};
}

template <typename T>
OnvifOutcome OnvifSession::check(const std::string& op, const onvif::Result<T>& r) const {
  if (r.ok()) {
    if (last_http_status_ != 200) {
      return {OnvifFailure::kMalformed, op + ": " + onvif::httpStatusText(last_http_status_)};
    }
    return {};
  }
  if (r.fault()) {
    const auto& f = *r.fault();
    return {OnvifFailure::kFault, op + ": SOAP fault " + f.code + " " + f.subcode +
                                      (f.reason.empty() ? "" : " (" + f.reason + ")")};
  }
  // No SOAP at all: an HTTP error page is not a malformed reply but a refusal.
  if (last_http_status_ != 200) {
    return {OnvifFailure::kFault, op + ": " + onvif::httpStatusText(last_http_status_)};
  }
  return {OnvifFailure::kMalformed, op + ": " + r.error()};
}

OnvifOutcome OnvifSession::checkSpaces(const onvif::PtzSpaces& s) const {
  if (continuous_) {
    if (!s.continuous_pan_tilt_velocity) {
      return {OnvifFailure::kMalformed, "GetNodes: no continuous pan/tilt velocity space"};
    }
    // Positions (GetStatus) are then in the generic spaces by default; none to check them by.
    if (!s.absolute_pan_tilt) return {};
  }
  // The model's angle map is in the generic spaces: pan, tilt -1..1, zoom 0..1.
  if (!s.absolute_pan_tilt || !near(s.absolute_pan_tilt->x, -1, 1) ||
      !near(s.absolute_pan_tilt->y, -1, 1)) {
    return {OnvifFailure::kMalformed,
            "GetNodes: no absolute pan/tilt space of -1..1 (the model's generic space)"};
  }
  if (!s.absolute_zoom || !near(s.absolute_zoom->x, 0, 1)) {
    return {OnvifFailure::kMalformed,
            "GetNodes: no absolute zoom space of 0..1 (the model's generic space)"};
  }
  return {};
}

OnvifOutcome OnvifSession::start() {
  started_ = false;
  best_round_trip_s_ = 1e300;
  const std::string device = deviceUrl(settings_.url);
  std::string body;
  // The camera's clock first (open to all): every token after is signed in its time.
  double t0 = 0, t1 = 0;
  offset_s_ = 0;
  OnvifOutcome o = post(device, onvif::getSystemDateAndTime(), &body, &t0, &t1);
  if (!o.ok()) return o;
  const auto clock = onvif::parseSystemDateAndTime(body);
  if (o = check("GetSystemDateAndTime", clock); !o.ok()) return o;
  // Whole seconds: the camera's time is somewhere in that second; its middle.
  offset_s_ = *clock + 0.5 - (t0 + t1) / 2;

  if (o = post(device, onvif::getCapabilities(), &body); !o.ok()) return o;
  auto services = onvif::parseCapabilities(body);
  if (services.fault()) return check("GetCapabilities", services);  // NotAuthorized and such
  if (!services.ok() || services->ptz_url.empty() || services->media_url.empty()) {
    if (o = post(device, onvif::getServices(), &body); !o.ok()) return o;  // older or newer
    services = onvif::parseServices(body);
    if (o = check("GetServices", services); !o.ok()) return o;
  }
  if (services->ptz_url.empty() || services->media_url.empty()) {
    return {OnvifFailure::kMalformed, "GetCapabilities: the camera has no PTZ or Media service"};
  }
  ptz_url_ = services->ptz_url;

  if (o = post(services->media_url, onvif::getProfiles(), &body); !o.ok()) return o;
  const auto profiles = onvif::parseProfiles(body);
  if (o = check("GetProfiles", profiles); !o.ok()) return o;
  const onvif::MediaProfile* chosen = nullptr;
  for (const auto& p : *profiles) {
    const bool named =
        settings_.profile.empty() || p.token == settings_.profile || p.name == settings_.profile;
    if (named && !p.ptz_configuration_token.empty()) {
      chosen = &p;
      break;
    }
  }
  if (!chosen) {
    return {OnvifFailure::kMalformed,
            "GetProfiles: no profile with a PTZ configuration" +
                (settings_.profile.empty() ? "" : " named '" + settings_.profile + "'")};
  }
  profile_ = chosen->token;

  if (o = post(ptz_url_, onvif::getNodes(), &body); !o.ok()) return o;
  const auto nodes = onvif::parseNodes(body);
  if (o = check("GetNodes", nodes); !o.ok()) return o;
  const onvif::PtzNode* node = nullptr;
  for (const auto& n : *nodes) {
    if (n.token == chosen->ptz_node_token || (!node && chosen->ptz_node_token.empty())) node = &n;
  }
  if (!node && !nodes->empty()) node = &nodes->front();
  if (!node) return {OnvifFailure::kMalformed, "GetNodes: no PTZ node"};
  continuous_ = settings_.move_mode == OnvifMoveMode::kContinuous ||
                (settings_.move_mode == OnvifMoveMode::kAuto && !node->spaces.absolute_pan_tilt);
  if (o = checkSpaces(node->spaces); !o.ok()) return o;

  if (o = post(ptz_url_, onvif::getConfigurationOptions(chosen->ptz_configuration_token), &body);
      !o.ok()) {
    return o;
  }
  const auto options = onvif::parseConfigurationOptions(body);
  if (o = check("GetConfigurationOptions", options); !o.ok()) return o;
  // A continuous move's timeout: 1 s, within what the camera allows.
  continuous_timeout_s_ = 1;
  if (options->timeout_s) {
    continuous_timeout_s_ = std::clamp(1.0, options->timeout_s->min,
                                       std::max(options->timeout_s->min, options->timeout_s->max));
  }
  started_ = true;
  return {};
}

OnvifOutcome OnvifSession::absoluteMove(const PtzPose& pose) {
  onvif::PtzVector v;
  v.pan_tilt =
      onvif::Vector2D{model_.panNormalised(pose.pan_rad), model_.tiltNormalised(pose.tilt_rad), ""};
  v.zoom = onvif::Vector1D{model_.zoomNormalised(pose.zoom), ""};
  std::string body;
  if (OnvifOutcome o = post(ptz_url_, onvif::absoluteMove(profile_, v), &body); !o.ok()) return o;
  return check("AbsoluteMove", onvif::parseEmptyPtzReply(body, "AbsoluteMoveResponse"));
}

OnvifOutcome OnvifSession::continuousMove(const PtzPose& target, const PtzPose& measured,
                                          double pan_rate_rad_s, double tilt_rate_rad_s) {
  auto velocity = [&](double error, double deadband, double feed_forward, double scale) {
    if (std::abs(error) < deadband && std::abs(feed_forward) < deadband) return 0.0;
    return std::clamp((feed_forward + settings_.continuous_gain_per_s * error) / scale, -1.0, 1.0);
  };
  const double speed = model_.pan_tilt_speed_max_rad_s;
  onvif::PtzVector v;
  v.pan_tilt = onvif::Vector2D{
      velocity(target.pan_rad - measured.pan_rad, kDeadbandRad, pan_rate_rad_s, speed),
      velocity(target.tilt_rad - measured.tilt_rad, kDeadbandRad, tilt_rate_rad_s, speed), ""};
  // Zoom in normalised units: its velocity 1 is the lens's full range in some seconds.
  v.zoom = onvif::Vector1D{
      velocity(model_.zoomNormalised(target.zoom) - model_.zoomNormalised(measured.zoom),
               kDeadbandZoom, 0.0, 1.0),
      ""};
  std::string body;
  if (OnvifOutcome o =
          post(ptz_url_, onvif::continuousMove(profile_, v, continuous_timeout_s_), &body);
      !o.ok()) {
    return o;
  }
  return check("ContinuousMove", onvif::parseEmptyPtzReply(body, "ContinuousMoveResponse"));
}

OnvifOutcome OnvifSession::stop() {
  std::string body;
  if (OnvifOutcome o = post(ptz_url_, onvif::stop(profile_, true, true), &body); !o.ok()) return o;
  return check("Stop", onvif::parseEmptyPtzReply(body, "StopResponse"));
}

OnvifOutcome OnvifSession::status(OnvifStatus* out) {
  std::string body;
  double t0 = 0, t1 = 0;
  if (OnvifOutcome o = post(ptz_url_, onvif::getStatus(profile_), &body, &t0, &t1); !o.ok()) {
    return o;
  }
  const auto s = onvif::parseStatus(body);
  if (OnvifOutcome o = check("GetStatus", s); !o.ok()) return o;
  if (!s->pan || !s->tilt) return {OnvifFailure::kMalformed, "GetStatus: no pan/tilt position"};
  out->pose = PtzPose{model_.panRad(*s->pan), model_.tiltRad(*s->tilt),
                      s->zoom ? model_.zoomRatio(*s->zoom) : model_.zoomRatio(0)};
  out->round_trip_ms = (t1 - t0) * 1e3;
  out->at_s = (t0 + t1) / 2;
  if (s->camera_utc_s) {
    // The fastest exchange lately sets the offset (ms, not GetSystemDateAndTime's seconds).
    const double rtt_s = t1 - t0;
    if (rtt_s <= best_round_trip_s_ || t1 - best_at_s_ > kBestSampleAgeS) {
      best_round_trip_s_ = rtt_s;
      best_at_s_ = t1;
      offset_s_ = *s->camera_utc_s - (t0 + t1) / 2;
    }
    // Measured while the request was out, whatever the offset's error.
    out->at_s = std::clamp(*s->camera_utc_s - offset_s_, t0, t1);
  }
  return {};
}

}  // namespace ptz::driver
