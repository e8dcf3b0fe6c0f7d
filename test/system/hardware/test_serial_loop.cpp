// The real ptz-driver on a serial line, as on hardware: a pseudo-terminal whose master end
// plays the heads (a daisy chain of two VISCA cameras, or a Pelco-D bus of two heads, moved by
// the shared plant model), the driver on the slave path as a user passes /dev/ttyUSB0, real
// LCM in a private network namespace. Setpoints in, PTZ_STATE at the setpoint, a setpoint
// beyond the limits clamped before it reaches the wire, and the stop bytes on SIGTERM.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "common/plant.hpp"
#include "common/transport/transport.hpp"
#include "ptz_driver/emulators/pelco_d_bus_emulator.hpp"
#include "ptz_driver/emulators/visca_chain_emulator.hpp"
#include "ptz_driver/heads/pelco_d/pelco_d.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "support/child_process.hpp"
#include "support/hardware/pty_pair.hpp"
#include "support/hardware/serial_serve.hpp"
#include "support/lcm_wait.hpp"

using namespace std::chrono_literals;
using namespace ptz::driver;
using ptz::test::ChildProcess;

namespace {
const std::string kConfig = PTZ_SOURCE_DIR "/config/";
constexpr double kPanMax = 1.0;  // --pan-max: the driver's limit, inside the heads' range

struct Watch {
  std::optional<ptzstereo::ptz_state_t> state;
  int64_t states = 0;
  std::map<std::string, int64_t> counters;  // ptz-driver's status
  int64_t statuses = 0;
  std::string message;  // of the last status
  void onState(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::ptz_state_t* m) {
    state = *m;
    ++states;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    for (const auto& c : m->counters) counters[c.name] = c.value;
    message = m->message;
    ++statuses;
  }
};

// Publishes the setpoint every 30 ms (the deadman is 0.25 s) until done() or the timeout.
bool holdSetpoint(lcm::LCM& lcm, const ptz::PtzPose& left, const ptz::PtzPose& right,
                  const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    ptzstereo::ptz_setpoint_t sp{};
    sp.utime = sp.publish_utime = ptz::wallUtime();
    sp.left = {left.pan_rad, left.tilt_rad, left.zoom};
    sp.right = {right.pan_rad, right.tilt_rad, right.zoom};
    lcm.publish("PTZ_SETPOINT", &sp);
    if (ptz::test::handleUntil(lcm, done, 30ms)) return true;
  }
  return done();
}

bool near(const ptzstereo::ptz_head_state_t& s, const ptz::PtzPose& p, double angle, double zoom) {
  return std::abs(s.pan_rad - p.pan_rad) <= angle && std::abs(s.tilt_rad - p.tilt_rad) <= angle &&
         std::abs(s.zoom - p.zoom) <= zoom;
}

// Runs the driver with `args` (the example config file and what a test overrides) against the
// emulator on a pty; `angle` is the bound on the
// state's distance from the setpoint once there (a few of the protocol's angle units).
// stopped(emulator): the heads got the stop bytes (waited for after the driver's exit).
// estimated: the heads cannot report their position (Pelco-D without queries).
template <class Emulator>
void followClampAndStop(Emulator* heads, const std::vector<std::string>& args, double angle,
                        const std::function<bool(Emulator&)>& stopped, bool estimated = false) {
  ptz::test::PtyPair pty;
  ptz::test::SerialServer<Emulator> server(pty, heads);
  lcm::LCM lcm(ptz::test::kTestUrl);
  Watch w;
  lcm.subscribe("PTZ_STATE", &Watch::onState, &w);
  lcm.subscribe("PROCESS_STATUS_PTZ_DRIVER", &Watch::onStatus, &w);
  std::vector<std::string> cmd = {
      PTZ_DRIVER_BIN,          "--lcm-url", ptz::test::kTestUrl, "--left-serial-device", pty.path(),
      "--right-serial-device", pty.path(),  "--pan-max",         std::to_string(kPanMax)};
  cmd.insert(cmd.end(), args.begin(), args.end());
  ChildProcess driver(cmd);
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.states >= 5; }, 15s))
      << "no PTZ_STATE from the driver";
  // Settled within `angle`: the slew (3 rad/s) and the motors (T 0.24 s) take ~1.5 s.
  const ptz::PtzPose left{0.5, 0.1, 2.0}, right{-0.4, 0.05, 3.0};
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_TRUE(holdSetpoint(
      lcm, left, right,
      [&] {
        return near(w.state->left, left, angle, 0.01) && near(w.state->right, right, angle, 0.01);
      },
      10s))
      << "left pan " << w.state->left.pan_rad << " tilt " << w.state->left.tilt_rad << " zoom "
      << w.state->left.zoom << ", right pan " << w.state->right.pan_rad;
  std::printf("at the setpoint within %.4f rad after %.2f s\n", angle,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  // Beyond the limit: the driver clamps to --pan-max, the heads never hear of more.
  const ptz::PtzPose beyond{3.0, 0.1, 2.0};
  EXPECT_TRUE(holdSetpoint(
      lcm, beyond, right,
      [&] {
        return near(w.state->left, {kPanMax, 0.1, 2.0}, angle, 0.01);
      },
      10s))
      << "left pan " << w.state->left.pan_rad;
  const double highest = server.with([](Emulator& e) {
    double h = -10;
    for (const auto& [head, target] : e.moves()) {
      if (head == 0 && target.pan_rad) h = std::max(h, *target.pan_rad);
    }
    return h;
  });
  EXPECT_LE(highest, kPanMax + angle / 2) << "a head was told to go beyond the limit";
  EXPECT_GT(highest, kPanMax - angle);
  // The head really is where PTZ_STATE says (for an estimate too: the same plant model).
  const double real_pan =
      server.with([&](Emulator& e) { return e.pose(0, server.nowS()).pan_rad; });
  EXPECT_NEAR(real_pan, w.state->left.pan_rad, angle);
  const int64_t statuses = w.statuses;  // a status from after all that (1 Hz)
  EXPECT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.statuses > statuses; }, 3s));
  std::printf("driver status: round trip p50 %.3f ms p99 %.3f ms, timeouts %lld, malformed %lld\n",
              w.counters["head_round_trip_us_p50"] / 1000.0,
              w.counters["head_round_trip_us_p99"] / 1000.0,
              static_cast<long long>(w.counters["head_timeouts"]),
              static_cast<long long>(w.counters["head_malformed"]));
  EXPECT_EQ(w.counters["head_errors"], 0);
  EXPECT_EQ(w.counters["position_estimated"], estimated ? 1 : 0);
  EXPECT_EQ(w.counters["head_malformed"], 0);
  EXPECT_EQ(driver.stop(), 0) << "SIGTERM: the driver stops the heads and exits cleanly";
  // The stop bytes left before the exit; the server may still be reading them.
  EXPECT_TRUE(server.waitFor(stopped, 2s)) << "the heads did not get the stop bytes";
}

// VISCA's moves carry optional targets; Pelco-D's whole poses: one shape for the check above.
struct PelcoMoves {
  PelcoDBusEmulator bus;
  std::vector<std::pair<int, ViscaTarget>> moves_;
  Bytes feed(const uint8_t* d, size_t n, double now_s) { return bus.feed(d, n, now_s); }
  ptz::PtzPose pose(int head, double now_s) { return bus.pose(head, now_s); }
  const std::vector<std::pair<int, ViscaTarget>>& moves() {
    moves_.clear();
    for (const auto& [head, p] : bus.moves())
      moves_.push_back({head, {p.pan_rad, p.tilt_rad, p.zoom}});
    return moves_;
  }
};
}  // namespace

TEST(SerialLoop, ViscaDaisyChainFollowsClampsAndStopsOnSigterm) {
  const std::string model_path = kConfig + "visca/sony_evi_d70.yaml";
  const ViscaModel model = ViscaModel::load(model_path);
  ViscaChainEmulator chain(model, ptz::defaultPlantParams(), 2);
  // A VISCA unit is 1.3 mrad: commands and answers are rounded to one; two units of bound.
  // The stops, at the end, for both cameras.
  auto stopped = [](ViscaChainEmulator& e) {
    const auto& got = e.received();
    const auto tail =
        got.end() - std::min<std::ptrdiff_t>(12, static_cast<std::ptrdiff_t>(got.size()));
    for (const int address : {1, 2}) {
      for (const Bytes& stop : {visca::panTiltStop(address, 24, 20), visca::zoomStop(address)}) {
        if (std::find(tail, got.end(), stop) == got.end()) return false;
      }
    }
    return true;
  };
  // A VISCA unit is 1.3 mrad: commands and answers are rounded to one; two units of bound.
  followClampAndStop<ViscaChainEmulator>(
      &chain, {"--config", kConfig + "driver_visca_serial.yaml", "--visca-model", model_path},
      2 / model.pan_units_per_rad, stopped);
  ASSERT_GE(chain.received().size(), 2u);
  EXPECT_EQ(chain.received()[0], visca::addressSet());
  EXPECT_EQ(chain.received()[1], visca::ifClear());
}

TEST(SerialLoop, PelcoDBusWithPositionQueriesFollowsClampsAndStopsOnSigterm) {
  const std::string model_path = kConfig + "pelco_d/generic.yaml";
  PelcoMoves heads{
      PelcoDBusEmulator(PelcoModel::load(model_path), ptz::defaultPlantParams(), {1, 2}, true), {}};
  auto stopped = [](PelcoMoves& e) {
    const auto& got = e.bus.received();
    const auto tail =
        got.end() - std::min<std::ptrdiff_t>(4, static_cast<std::ptrdiff_t>(got.size()));
    return std::find(tail, got.end(), pelco_d::stop(1)) != got.end() &&
           std::find(tail, got.end(), pelco_d::stop(2)) != got.end();
  };
  // A hundredth of a degree is 0.17 mrad; the bound is a few of them.
  followClampAndStop<PelcoMoves>(&heads,
                                 {"--config", kConfig + "driver_pelco_d.yaml", "--pelco-model",
                                  model_path, "--pelco-position-query", "1"},
                                 5 * M_PI / 18000, stopped);
  EXPECT_EQ(heads.bus.badChecksums(), 0);
}

// Most Pelco-D heads cannot say where they are: PTZ_STATE is the plant model's estimate, which
// starts once the heads must be home (2.3 s), and the status says so.
TEST(SerialLoop, PelcoDBusWithoutQueriesReportsTheEstimate) {
  const std::string model_path = kConfig + "pelco_d/generic.yaml";
  PelcoMoves heads{
      PelcoDBusEmulator(PelcoModel::load(model_path), ptz::defaultPlantParams(), {1, 2}, false),
      {}};
  auto stopped = [](PelcoMoves& e) {
    const auto& got = e.bus.received();
    return !got.empty() && got.back() == pelco_d::stop(2);
  };
  followClampAndStop<PelcoMoves>(
      &heads, {"--config", kConfig + "driver_pelco_d.yaml", "--pelco-model", model_path},
      5 * M_PI / 18000, stopped, true);
  const auto& got = heads.bus.received();
  ASSERT_GE(got.size(), 6u);
  EXPECT_EQ(got[0], pelco_d::setPanPosition(1, 0));  // home first
}

// The adapter unplugged while the driver runs, then plugged back in as another tty (its
// /dev/serial/by-id/ link re-pointed): the status names the device and the next attempt, the
// driver reopens it by itself and the heads follow setpoints again.
TEST(SerialLoop, AnAdapterPluggedBackIsReopenedAndTheHeadsFollowAgain) {
  const std::string model_path = kConfig + "visca/sony_evi_d70.yaml";
  const ViscaModel model = ViscaModel::load(model_path);
  ViscaChainEmulator chain(model, ptz::defaultPlantParams(), 2);
  ViscaChainEmulator plugged_back(model, ptz::defaultPlantParams(), 2);  // outlives the servers
  auto pty = std::make_unique<ptz::test::PtyPair>();
  ptz::test::DeviceLink link(pty->path());
  auto server = std::make_unique<ptz::test::SerialServer<ViscaChainEmulator>>(*pty, &chain);
  lcm::LCM lcm(ptz::test::kTestUrl);
  Watch w;
  lcm.subscribe("PTZ_STATE", &Watch::onState, &w);
  lcm.subscribe("PROCESS_STATUS_PTZ_DRIVER", &Watch::onStatus, &w);
  ChildProcess driver({PTZ_DRIVER_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                       kConfig + "driver_visca_serial.yaml", "--visca-model", model_path,
                       "--left-serial-device", link.path(), "--right-serial-device", link.path()});
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.states >= 5; }, 15s))
      << "no PTZ_STATE from the driver";

  server.reset();
  pty->hangUp();
  link.remove();
  const std::string device = "serial device '" + link.path() + "'";
  EXPECT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return w.message.find(device + " does not exist") == 0; }, 10s))
      << "status: " << w.message;
  EXPECT_NE(w.message.find(", reopening in "), std::string::npos) << w.message;
  EXPECT_EQ(w.counters["head_errors"], 1);
  EXPECT_EQ(w.counters["head_reopens"], 0);

  pty = std::make_unique<ptz::test::PtyPair>();
  server = std::make_unique<ptz::test::SerialServer<ViscaChainEmulator>>(*pty, &plugged_back);
  link.pointTo(pty->path());
  const ptz::PtzPose left{0.5, 0.1, 2.0}, right{-0.4, 0.05, 3.0};
  const double angle = 2 / model.pan_units_per_rad;
  EXPECT_TRUE(holdSetpoint(
      lcm, left, right,
      [&] {
        return w.counters["head_reopens"] == 1 && near(w.state->left, left, angle, 0.01) &&
               near(w.state->right, right, angle, 0.01);
      },
      20s))
      << "reopens " << w.counters["head_reopens"] << ", status: " << w.message;
  EXPECT_EQ(w.counters["head_errors"], 1);
  EXPECT_TRUE(server->waitFor(
      [](ViscaChainEmulator& e) {
        return e.received().size() >= 2 && e.received()[0] == visca::addressSet() &&
               e.received()[1] == visca::ifClear();
      },
      2s))
      << "the chain is addressed again";
  EXPECT_EQ(driver.stop(), 0);
}
