// An ONVIF Profile S PTZ camera emulator: SOAP 1.2 request bytes in, reply bytes out (no
// sockets: sim/onvif_server.* carries them over HTTP). Device, Media and PTZ operations in the
// shapes of ONVIF's WSDLs; WS-UsernameToken digest authentication against the camera's own clock
// (host clock + a settable offset, as a camera whose clock nobody set); the head's motion as
// setpoints for the simulator's plant (setpoint()), its position read back from the plant.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "common/rig.hpp"  // PtzPose
#include "ptz_driver/heads/onvif/head/onvif_model.hpp"
#include "ptz_driver/heads/onvif/xml.hpp"

namespace ptz::driver {

struct OnvifCameraSettings {
  std::string user = "admin";
  std::string password;          // empty: no authentication
  double clock_offset_s = 0;     // the camera's clock minus the host's
  std::string serial = "SIM-0";  // GetDeviceInformation's SerialNumber
  double created_window_s = 5;   // a UsernameToken's Created must be this close to the camera
};

struct OnvifReply {
  int http_status = 200;  // 200; SOAP 1.2 over HTTP: 400 for env:Sender, 500 for env:Receiver
  std::string body;
  // A cheap camera's GetStatus: send the reply this much later (the position is the request's).
  double delay_s = 0;
};

class OnvifCameraEmulator {
 public:
  OnvifCameraEmulator(OnvifModel model, OnvifCameraSettings settings, const PtzPose& home = {});

  // One SOAP envelope while the head is at `now` and the host clock reads host_now_s (Unix s).
  // xaddr_base ("http://127.0.0.1:8000") is where the services are, as the client reached us.
  OnvifReply handle(std::string_view request, const std::string& xaddr_base, const PtzPose& now,
                    double host_now_s);
  // Where the plant should head at host_now_s: moves ramp the setpoint at their speed, continuous
  // moves run until Stop or their timeout.
  PtzPose setpoint(double host_now_s) const;

  double cameraNow(double host_now_s) const { return host_now_s + settings_.clock_offset_s; }
  void setClockOffset(double offset_s) { settings_.clock_offset_s = offset_s; }
  const OnvifModel& model() const { return model_; }
  int64_t faults() const { return faults_; }
  int64_t authRefused() const { return auth_refused_; }

 private:
  // Normalised pan, tilt (-1..1) and zoom (0..1), and a motion between two of them.
  using Vec3 = std::array<double, 3>;
  struct Motion {
    Vec3 from{0, 0, 0}, to{0, 0, 0};
    Vec3 rate_per_s{};     // normalised units per second; <= 0: at once
    double t0_s = 0;       // host clock
    double end_s = 1e300;  // a continuous move's timeout: the setpoint freezes there
  };
  // The reply's Body content for operation `op`; throws for a fault.
  std::string dispatch(const onvif::XmlNode& op, const std::string& xaddr, const PtzPose& now,
                       double host_now_s, double* delay_s);
  void checkAuth(const onvif::XmlNode& envelope, double host_now_s) const;
  Vec3 normalised(const PtzPose& pose) const;
  PtzPose pose(const Vec3& v) const;
  Vec3 evaluate(const Motion& m, double host_now_s) const;
  // Speeds in the generic speed space (0..1, per axis); none: at once.
  void moveTo(const Vec3& to, const std::optional<Vec3>& speed, double host_now_s);

  OnvifModel model_;
  OnvifCameraSettings settings_;
  Motion motion_;
  struct Preset {
    std::string name;
    Vec3 position;
  };
  std::map<std::string, Preset> presets_;
  int next_preset_ = 1;
  int64_t faults_ = 0, auth_refused_ = 0;
};

}  // namespace ptz::driver
