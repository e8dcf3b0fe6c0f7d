#include "ptz_driver/head_factory.hpp"

#include "ptz_driver/gpio_factory.hpp"
#include "ptz_driver/visca_ip_head.hpp"

namespace ptz::driver {

void declareBackendParams(Params& p) {
  p.add("backend", "visca_ip", "visca_ip or gpio (serial VISCA and Pelco-D heads: not yet)");
  p.add("visca_model", "", "VISCA camera model file (config/visca/*.yaml); required for VISCA");
  p.add("left_host", "127.0.0.1", "left camera's IPv4 address");
  p.add("left_port", 52381, "", "left camera's VISCA-over-IP UDP port");
  p.add("right_host", "127.0.0.1", "right camera's IPv4 address");
  p.add("right_port", 52382, "", "right camera's VISCA-over-IP UDP port");
  declareGpioParams(p);  // backend gpio: DC motors, encoders and limit switches on GPIO lines
}

std::array<std::unique_ptr<PtzHead>, 2> makeHeads(const Params& p) {
  const std::string backend = p.getString("backend");
  std::array<std::unique_ptr<PtzHead>, 2> heads;
  if (backend == "visca_ip") {
    if (p.getString("visca_model").empty())
      throw ConfigError("parameter 'visca_model' is required with backend visca_ip");
    const ViscaModel model = ViscaModel::load(p.getString("visca_model"));
    heads[0] =
        std::make_unique<ViscaIpHead>(model, p.getString("left_host"), p.getInt("left_port"));
    heads[1] =
        std::make_unique<ViscaIpHead>(model, p.getString("right_host"), p.getInt("right_port"));
    return heads;
  }
  if (backend == "gpio") return makeGpioHeads(p);
  throw ConfigError("parameter 'backend': unknown backend '" + backend + "' (visca_ip, gpio)");
}

}  // namespace ptz::driver
