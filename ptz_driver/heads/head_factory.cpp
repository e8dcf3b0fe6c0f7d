#include "ptz_driver/heads/head_factory.hpp"

#include <stdexcept>

#include "common/plant.hpp"
#include "ptz_driver/heads/gpio/gpio_backend.hpp"
#include "ptz_driver/heads/onvif/head/onvif_head.hpp"
#include "ptz_driver/heads/pelco_d/pelco_d_head.hpp"
#include "ptz_driver/heads/visca/visca_ip_head.hpp"
#include "ptz_driver/heads/visca/visca_serial_head.hpp"

namespace ptz::driver {

void declareBackendParams(Params& p) {
  p.add("backend", "visca_ip", "visca_ip, visca_serial, pelco_d, gpio or onvif");
  p.add("visca_model", "",
        "backend visca_ip, visca_serial: camera model file (config/visca/*.yaml); required");
  p.add("left_host", "127.0.0.1", "backend visca_ip: left camera's IPv4 address");
  p.add("left_port", 52381, "", "backend visca_ip: left camera's UDP port",
        Range::between(1, 65535));
  p.add("right_host", "127.0.0.1", "backend visca_ip: right camera's IPv4 address");
  p.add("right_port", 52382, "", "backend visca_ip: right camera's UDP port",
        Range::between(1, 65535));
  p.add("left_serial_device", "/dev/ttyUSB0",
        "backend visca_serial, pelco_d: left head's serial port");
  p.add("right_serial_device", "/dev/ttyUSB0",
        "backend visca_serial, pelco_d: right head's serial port; the left's: both on one line "
        "(daisy chain, RS-485 bus)");
  p.add("serial_baud", 9600, "baud",
        "backend visca_serial: baud rate (2400 .. 115200, the camera's)",
        Range::between(2400, 115200));
  p.add("left_visca_address", 1, "",
        "backend visca_serial: left camera's address (1: first on the chain)",
        Range::between(1, 7));
  p.add("right_visca_address", 0, "",
        "backend visca_serial: right camera's address; 0: 2 on the left's line, 1 on a line of "
        "its own",
        Range::between(0, 7));
  p.add("pelco_model", "", "backend pelco_d: head model file (config/pelco_d/*.yaml); required");
  p.add("pelco_baud", 2400, "baud", "backend pelco_d: baud rate (the heads' DIP switches)",
        Range::between(2400, 115200));
  p.add("left_pelco_address", 1, "", "backend pelco_d: left head's address (DIP switches)",
        Range::between(1, 255));
  p.add("right_pelco_address", 2, "", "backend pelco_d: right head's address (DIP switches)",
        Range::between(1, 255));
  p.add("pelco_position_query", false,
        "backend pelco_d: the heads answer position queries 0x51/0x53/0x55 (else the position "
        "is estimated)");
  p.add("pelco_time_constant_s", defaultPlantParams().axis[0].time_constant_s, "s",
        "backend pelco_d without position queries: time constant of the estimated motion "
        "of every axis",
        Range::above(0));
  p.add("onvif_left_url", "http://127.0.0.1:8080",
        "backend onvif: left camera (http://host:port; ptz-sim --onvif-port 8080 serves it)");
  p.add("onvif_right_url", "http://127.0.0.1:8081",
        "backend onvif: right camera (http://host:port; ptz-sim: the left's port + 1)");
  p.add("onvif_user", "admin", "backend onvif: user of the WS-UsernameToken");
  p.add("onvif_password_file", "",
        "backend onvif: file whose first line is the cameras' password (else env "
        "PTZ_ONVIF_PASSWORD; neither: requests unsigned)");
  p.add("onvif_model", "config/onvif/generic_ptz.yaml",
        "backend onvif: camera model file (config/onvif/*.yaml: the angle map)");
  p.add("onvif_profile", "",
        "backend onvif: media profile (token or name); empty: the first with PTZ");
  p.add("onvif_timeout_ms", 1000.0, "ms",
        "backend onvif: a request unanswered this long is a timeout (the camera is then "
        "started again)",
        Range::between(10, 60000));
  p.add("onvif_status_rate_hz", 25.0, "Hz", "backend onvif: GetStatus at most this often",
        Range::between(0.5, 200));
  p.add("onvif_move_mode", "auto",
        "backend onvif: auto (AbsoluteMove where the camera has it, else ContinuousMove), "
        "absolute, or continuous (ContinuousMove's velocity toward the setpoint, for cameras "
        "whose absolute moves are slow)");
  p.add("onvif_continuous_gain", 2.0, "1/s",
        "backend onvif, move mode continuous: velocity = gain x the error", Range::above(0));
  declareGpioParams(p);  // backend gpio: DC motors, encoders and limit switches on GPIO lines
}

namespace {

std::string required(const Params& p, const std::string& name, const std::string& backend) {
  if (p.getString(name).empty()) {
    throw ConfigError("parameter '" + name + "' is required with backend " + backend);
  }
  return p.getExistingPath(name);
}

// The lines of the two heads: one shared when both name the same device.
template <class Line>
std::array<std::shared_ptr<Line>, 2> openLines(const Params& p, const std::string& baud) {
  checkBaud(p.getInt(baud), baud);
  std::array<std::shared_ptr<Line>, 2> lines;
  const char* const names[2] = {"left_serial_device", "right_serial_device"};
  for (size_t i = 0; i < 2; ++i) {
    const std::string device = p.getString(names[i]);
    if (i == 1 && device == p.getString(names[0])) {
      lines[1] = lines[0];
      break;
    }
    try {
      lines[i] = std::make_shared<Line>(device, p.getInt(baud), baud);
    } catch (const std::runtime_error& e) {
      throw ConfigError("parameter '" + std::string(names[i]) + "': " + e.what());
    }
  }
  return lines;
}

// The model's map replaced by the identity: pan and tilt -1..1 as "radians", zoom 0..1 as 1..2.
OnvifModel unitModel(OnvifModel m) {
  const double pan_units_per_rad = 2 / (m.pan_max_rad - m.pan_min_rad);
  m.pan_tilt_speed_max_rad_s *= pan_units_per_rad;
  m.pan_min_rad = m.tilt_min_rad = -1;
  m.pan_max_rad = m.tilt_max_rad = 1;
  m.zoom_normalised = {0, 1};
  m.zoom_ratios = {1, 2};
  return m;
}

// Units as "radians" (one unit a radian), zoom positions 0..P as ratios 1..P+1.
ViscaModel unitModel(ViscaModel m) {
  m.pan_min_rad *= m.pan_units_per_rad;
  m.pan_max_rad *= m.pan_units_per_rad;
  m.tilt_min_rad *= m.tilt_units_per_rad;
  m.tilt_max_rad *= m.tilt_units_per_rad;
  m.pan_units_per_rad = m.tilt_units_per_rad = 1;
  const double last = m.zoom.positions.back();
  m.zoom.positions = {0, last};
  m.zoom.ratios = {1, last + 1};
  return m;
}

std::array<std::unique_ptr<PtzHead>, 2> makeOnvifHeads(const Params& p, bool units) {
  OnvifModel model = OnvifModel::load(required(p, "onvif_model", "onvif"));
  if (units) model = unitModel(std::move(model));
  OnvifHeadSettings s;
  s.user = p.getString("onvif_user");
  s.password = onvifHeadPassword(p.getPath("onvif_password_file"));
  s.profile = p.getString("onvif_profile");
  s.timeout_ms = p.getDouble("onvif_timeout_ms");
  s.status_rate_hz = p.getDouble("onvif_status_rate_hz");
  s.continuous_gain_per_s = p.getDouble("onvif_continuous_gain");
  const std::string mode = p.getString("onvif_move_mode");
  if (mode != "auto" && mode != "absolute" && mode != "continuous") {
    throw p.invalid("onvif_move_mode", "must be auto, absolute or continuous");
  }
  s.move_mode = mode == "continuous" ? OnvifMoveMode::kContinuous
                : mode == "absolute" ? OnvifMoveMode::kAbsolute
                                     : OnvifMoveMode::kAuto;
  std::array<std::unique_ptr<PtzHead>, 2> heads;
  const char* const urls[2] = {"onvif_left_url", "onvif_right_url"};
  for (size_t i = 0; i < 2; ++i) {
    s.url = p.getString(urls[i]);
    if (s.url.rfind("http://", 0) != 0 && s.url.rfind("https://", 0) != 0) {
      throw p.invalid(urls[i], "must be http://host:port or https://host:port");
    }
    heads[i] = std::make_unique<OnvifHead>(model, s);
  }
  return heads;
}

std::array<std::unique_ptr<PtzHead>, 2> makeHeadsIn(const Params& p,
                                                    const GpioChipOpener& open_gpio, bool units) {
  const std::string backend = p.getString("backend");
  if (units && backend != "onvif" && backend != "visca_ip" && backend != "visca_serial") {
    throw p.invalid("backend",
                    "must be onvif, visca_ip or visca_serial to measure the angle map "
                    "(a " +
                        backend + " head has no position units)");
  }
  const auto visca_model = [&] {
    ViscaModel m = ViscaModel::load(required(p, "visca_model", backend));
    return units ? unitModel(std::move(m)) : m;
  };
  std::array<std::unique_ptr<PtzHead>, 2> heads;
  if (backend == "visca_ip") {
    const ViscaModel model = visca_model();
    heads[0] =
        std::make_unique<ViscaIpHead>(model, p.getString("left_host"), p.getInt("left_port"));
    heads[1] =
        std::make_unique<ViscaIpHead>(model, p.getString("right_host"), p.getInt("right_port"));
    return heads;
  }
  if (backend == "visca_serial") {
    const ViscaModel model = visca_model();
    const bool shared = p.getString("left_serial_device") == p.getString("right_serial_device");
    const int left = p.getInt("left_visca_address");  // addresses and ports: ranged
    const int right =
        p.getInt("right_visca_address") == 0 ? (shared ? 2 : 1) : p.getInt("right_visca_address");
    if (shared && left == right) {
      throw p.invalid("right_visca_address",
                      "must differ from left_visca_address: two cameras on one line need two "
                      "addresses");
    }
    const auto lines = openLines<ViscaSerialLine>(p, "serial_baud");
    heads[0] = std::make_unique<ViscaSerialHead>(model, lines[0], left);
    heads[1] = std::make_unique<ViscaSerialHead>(model, lines[1], right);
    return heads;
  }
  if (backend == "pelco_d") {
    const PelcoModel model = PelcoModel::load(required(p, "pelco_model", backend));
    const int left = p.getInt("left_pelco_address");
    const int right = p.getInt("right_pelco_address");
    if (p.getString("left_serial_device") == p.getString("right_serial_device") && left == right) {
      throw p.invalid("right_pelco_address",
                      "must differ from left_pelco_address: two heads on one bus need two "
                      "addresses");
    }
    const auto lines = openLines<PelcoDLine>(p, "pelco_baud");
    const bool query = p.getBool("pelco_position_query");
    // The estimate: each axis a first-order lag within the limits, at most max_rate fast.
    PtzPlant::Params plant = axisLimitsFrom(p);
    const double time_constant_s = p.getDouble("pelco_time_constant_s");
    for (AxisParams& a : plant.axis) a.time_constant_s = time_constant_s;
    heads[0] = std::make_unique<PelcoDHead>(model, lines[0], left, query, plant);
    heads[1] = std::make_unique<PelcoDHead>(model, lines[1], right, query, plant);
    return heads;
  }
  if (backend == "gpio") return makeGpioHeads(p, open_gpio);
  if (backend == "onvif") return makeOnvifHeads(p, units);
  throw p.invalid("backend", "must be visca_ip, visca_serial, pelco_d, gpio or onvif");
}

}  // namespace

std::array<std::unique_ptr<PtzHead>, 2> makeHeads(const Params& p,
                                                  const GpioChipOpener& open_gpio) {
  return makeHeadsIn(p, open_gpio, false);
}

std::array<std::unique_ptr<PtzHead>, 2> makeUnitHeads(const Params& p) {
  return makeHeadsIn(p, openHeadLines, true);
}

}  // namespace ptz::driver
