// One ONVIF camera's PTZ service, blocking (libcurl): the start-up (the camera's clock, the
// services' addresses, the profile, the spaces checked against the model) and the requests the
// head sends (moves, Stop, GetStatus), each signed with a UsernameToken in the camera's time.
// Used by one thread, OnvifHead's worker; no LCM, no threads of its own.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "common/rig.hpp"  // PtzPose
#include "ptz_driver/heads/onvif/head/onvif_model.hpp"
#include "ptz_driver/heads/onvif/http.hpp"
#include "ptz_driver/heads/onvif/ptz_replies.hpp"
#include "ptz_driver/heads/onvif/requests.hpp"

namespace ptz::driver {

// kAuto: AbsoluteMove where the camera has it, else ContinuousMove.
enum class OnvifMoveMode { kAuto, kAbsolute, kContinuous };

struct OnvifHeadSettings {
  std::string url =
      "http://127.0.0.1:8080";  // the camera; its device service is /onvif/device_service
  std::string user = "admin";
  std::string password;  // empty: requests are not signed
  std::string profile;   // a media profile's token or name; empty: the first with PTZ
  double timeout_ms = 1000;
  double status_rate_hz = 25;  // GetStatus at most this often
  OnvifMoveMode move_mode = OnvifMoveMode::kAuto;
  double continuous_gain_per_s = 4;  // continuous mode: velocity = gain x error
};

// Why a request failed, for the head's counters: no answer (timeout; transport: refused, closed,
// unreachable), a refusal (a SOAP fault, an HTTP error), a reply that does not read.
enum class OnvifFailure { kNone, kTimeout, kFault, kMalformed, kTransport };

struct OnvifOutcome {
  OnvifFailure failure = OnvifFailure::kNone;
  std::string text;  // what failed, with the operation ("GetStatus: timeout (...)")
  bool ok() const { return failure == OnvifFailure::kNone; }
};

struct OnvifStatus {
  PtzPose pose;
  double at_s = 0;  // when the camera measured it, on the local clock
  double round_trip_ms = 0;
};

class OnvifSession {
 public:
  // now_s: the local clock (ptz-driver's, the wall clock).
  OnvifSession(OnvifModel model, OnvifHeadSettings settings, std::function<double()> now_s);

  // GetSystemDateAndTime, GetCapabilities, GetProfiles, GetNodes, GetConfigurationOptions.
  OnvifOutcome start();
  bool started() const { return started_; }
  // After start(): whether moves are ContinuousMove's velocities (the mode, or kAuto on a camera
  // without absolute spaces).
  bool continuousMoves() const { return continuous_; }
  // AbsoluteMove to pose through the model's angle map.
  OnvifOutcome absoluteMove(const PtzPose& pose);
  // ContinuousMove toward target from measured: the target's own pan/tilt rate (rad/s, fed
  // forward) plus gain x the error; a 1 s timeout so a camera left alone stops by itself.
  OnvifOutcome continuousMove(const PtzPose& target, const PtzPose& measured,
                              double pan_rate_rad_s = 0, double tilt_rate_rad_s = 0);
  OnvifOutcome stop();
  OnvifOutcome status(OnvifStatus* out);

  // The camera's UTC minus the local clock.
  double clockOffsetS() const { return offset_s_; }
  const std::string& profileToken() const { return profile_; }
  const OnvifModel& model() const { return model_; }
  int64_t requests() const { return requests_; }  // sent, answered or not

 private:
  // Posts the request (signed when there is a password); the reply's body in *body.
  OnvifOutcome post(const std::string& url, const onvif::Request& r, std::string* body,
                    double* sent_s = nullptr, double* received_s = nullptr);
  template <typename T>
  OnvifOutcome check(const std::string& op, const onvif::Result<T>& r) const;
  OnvifOutcome checkSpaces(const onvif::PtzSpaces& spaces) const;

  OnvifModel model_;
  OnvifHeadSettings settings_;
  std::function<double()> now_s_;
  onvif::HttpClient http_;
  onvif::HttpOptions http_options_;
  bool started_ = false;
  std::string ptz_url_, profile_;
  bool continuous_ = false;
  double offset_s_ = 0;
  // The offset from GetStatus's UtcTime (ms) of the fastest exchange lately: better than
  // GetSystemDateAndTime's whole seconds.
  double best_round_trip_s_ = 1e300, best_at_s_ = 0;
  double continuous_timeout_s_ = 1;
  long last_http_status_ = 0;
  int64_t requests_ = 0;
};

}  // namespace ptz::driver
