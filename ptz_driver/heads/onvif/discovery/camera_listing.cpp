#include "ptz_driver/heads/onvif/discovery/camera_listing.hpp"

#include <chrono>
#include <optional>

#include "ptz_driver/heads/onvif/device_replies.hpp"
#include "ptz_driver/heads/onvif/http.hpp"
#include "ptz_driver/heads/onvif/requests.hpp"

namespace ptz::onvif {
namespace {

double nowS() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

class Caller {
 public:
  Caller(const std::string& user, const std::string& password, int timeout_ms)
      : user_(user), password_(password) {
    options_.connect_timeout_ms = timeout_ms;
    options_.total_timeout_ms = timeout_ms;
    options_.http_user = user;
    options_.http_password = password;
  }

  // The reply's body; an error names the operation, and a 401 says authentication.
  Result<std::string> call(const std::string& url, const Request& r, bool sign = true) {
    const std::string op = r.action.substr(r.action.rfind('/') + 1);
    std::optional<UsernameToken> token;
    if (sign && !password_.empty()) token = makeUsernameToken(user_, password_, nowS() + offset_s);
    const auto reply = http_.post(url, r.action, envelope(r.body, token), options_);
    if (!reply) return Error{op + ": " + reply.error(), std::nullopt};
    status_ = reply->status;
    return reply->body;
  }

  template <typename T>
  std::string failure(const std::string& op, const Result<T>& r) const {
    if (r.fault()) {
      return op + ": SOAP fault " + r.fault()->code + " " + r.fault()->subcode +
             (r.fault()->reason.empty() ? "" : " (" + r.fault()->reason + ")");
    }
    if (status_ != 200) return op + ": " + httpStatusText(status_);
    return op + ": " + r.error();
  }

  double offset_s = 0;  // the camera's clock minus ours

 private:
  std::string user_, password_;
  HttpOptions options_;
  HttpClient http_;
  long status_ = 0;
};

}  // namespace

CameraListing listStreams(const std::string& device_url, const std::string& user,
                          const std::string& password, int timeout_ms) {
  CameraListing out;
  Caller caller(user, password, timeout_ms);
  // The camera's clock first (open to all): the tokens after are signed in its time.
  auto body = caller.call(device_url, getSystemDateAndTime(), false);
  if (!body) return {{}, body.error()};
  const auto clock = parseSystemDateAndTime(*body);
  if (!clock) return {{}, caller.failure("GetSystemDateAndTime", clock)};
  caller.offset_s = *clock + 0.5 - nowS();

  if (body = caller.call(device_url, getCapabilities()); !body) return {{}, body.error()};
  auto services = parseCapabilities(*body);
  if (!services.ok() && !services.fault()) {
    if (body = caller.call(device_url, getServices()); !body) return {{}, body.error()};
    services = parseServices(*body);
  }
  if (!services) return {{}, caller.failure("GetCapabilities", services)};
  if (services->media_url.empty()) return {{}, "GetCapabilities: the camera has no Media service"};

  if (body = caller.call(services->media_url, getProfiles()); !body) return {{}, body.error()};
  const auto profiles = parseProfiles(*body);
  if (!profiles) return {{}, caller.failure("GetProfiles", profiles)};
  for (const MediaProfile& p : *profiles) {
    if (body = caller.call(services->media_url, getStreamUri(p.token)); !body) {
      out.error = body.error();
      return out;
    }
    const auto uri = parseStreamUri(*body);
    if (!uri) {
      out.error = caller.failure("GetStreamUri '" + p.token + "'", uri);
      return out;
    }
    out.streams.push_back({p.token, p.name, p.video_width_px, p.video_height_px,
                           !p.ptz_configuration_token.empty(), *uri});
  }
  return out;
}

}  // namespace ptz::onvif
