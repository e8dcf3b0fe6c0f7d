// ptz-sim's heads as ONVIF cameras, driven by an independent client (the npm package `onvif`,
// test/js/onvif_client_check.js): ptz-sim a real process in a private network namespace, a
// password from a file, the cameras' clock an hour off the host's (the client must correct for
// it). The position the client reads back is the one it asked for, and the simulator's truth
// (SIM_TRUTH) is the model's degrees for it.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

#include "ptz_driver/heads/onvif/head/onvif_model.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/mcap_check.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

const std::vector<std::string> kOnvifPackages = {"onvif"};

struct Truth {
  ptzstereo::sim_truth_t last;
  int64_t count = 0;
  std::map<std::string, int64_t> sim_counters;
  void onTruth(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::sim_truth_t* m) {
    last = *m;
    ++count;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    if (m->process != "ptz-sim") return;
    for (const auto& c : m->counters) sim_counters[c.name] = c.value;
  }
};

// A blocking client socket with the request sent (-1 when ptz-sim does not take it).
int sendRequest(int port, const std::string& path, const std::string& body) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  timeval timeout{30, 0};  // generous: the machine is loaded
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  ::inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
  const std::string request = "POST " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: " +
                              std::to_string(body.size()) + "\r\n\r\n" + body;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
      ::send(fd, request.data(), request.size(), MSG_NOSIGNAL) !=
          static_cast<ssize_t>(request.size())) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// The whole response (head and Content-Length bytes of body); "" on a timeout or a close.
std::string readResponse(int fd) {
  std::string in;
  char buf[8192];
  for (;;) {
    const size_t end = in.find("\r\n\r\n");
    if (end != std::string::npos) {
      const size_t cl = in.find("Content-Length: ");
      const size_t length = cl < end ? std::stoul(in.substr(cl + 16)) : 0;
      if (in.size() >= end + 4 + length) return in;
    }
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) return "";
    in.append(buf, static_cast<size_t>(n));
  }
}

std::string soap(const std::string& op, const std::string& ns, const std::string& inner = "") {
  return "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"><s:Body><" + op +
         " xmlns=\"" + ns + "\">" + inner + "</" + op + "></s:Body></s:Envelope>";
}

}  // namespace

TEST(OnvifSim, ACheapCamerasLateStatusDoesNotHoldTheOtherCamera) {
  // The cheap model with a 2 s GetStatus: far beyond any hiccup of a loaded machine.
  const std::string model_file = "/tmp/ptz_onvif_cheap_" + std::to_string(getpid()) + ".yaml";
  {
    std::ifstream in(PTZ_SOURCE_DIR "/config/onvif/cheap_ptz.yaml");
    std::ofstream out(model_file);
    for (std::string line; std::getline(in, line);) {
      out << (line.rfind("status_delay_ms:", 0) == 0 ? "status_delay_ms: 2000" : line) << "\n";
    }
  }
  lcm::LCM lcm(ptz::test::kTestUrl);
  ASSERT_TRUE(lcm.good());
  Truth truth;
  lcm.subscribe("SIM_TRUTH", &Truth::onTruth, &truth);
  lcm.subscribe("PROCESS_STATUS_.*", &Truth::onStatus, &truth);
  const int port = 18570;
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                    PTZ_SOURCE_DIR "/config/sim_default.yaml", "--encoding", "jpeg", "--duration-s",
                    "120", "--onvif-port", std::to_string(port), "--onvif-model", model_file,
                    "--status-period-s", "0.2"});
  ASSERT_TRUE(sim.started());
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return truth.count > 0; }, 30s))
      << "ptz-sim published no SIM_TRUTH";
  const auto t0 = std::chrono::steady_clock::now();
  const int late = sendRequest(port, "/onvif/ptz_service",
                               soap("GetStatus", "http://www.onvif.org/ver20/ptz/wsdl",
                                    "<ProfileToken>profile_1</ProfileToken>"));
  const int quick =
      sendRequest(port + 1, "/onvif/device_service",
                  soap("GetDeviceInformation", "http://www.onvif.org/ver10/device/wsdl"));
  ASSERT_GE(late, 0);
  ASSERT_GE(quick, 0);
  const std::string q = readResponse(quick);
  const auto t_quick = std::chrono::steady_clock::now();
  const std::string l = readResponse(late);
  const auto t_late = std::chrono::steady_clock::now();
  ::close(quick);
  ::close(late);
  EXPECT_EQ(q.rfind("HTTP/1.1 200", 0), 0u) << q;
  EXPECT_NE(q.find("CheapDome-2"), std::string::npos);
  EXPECT_EQ(l.rfind("HTTP/1.1 200", 0), 0u) << l;
  EXPECT_NE(l.find("GetStatusResponse"), std::string::npos);
  // The late answer came no earlier than its delay; the other camera's before it was due (the
  // loop was not held).
  EXPECT_GE(t_late - t0, 1900ms);
  EXPECT_LT(t_quick - t0, 1900ms);
  // Bad HTTP is refused and counted in ptz-sim's status, as the VISCA cameras count theirs.
  const int bad = sendRequest(port, "/nowhere", "x");
  ASSERT_GE(bad, 0);
  EXPECT_EQ(readResponse(bad).rfind("HTTP/1.1 404", 0), 0u);
  ::close(bad);
  EXPECT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return truth.sim_counters["onvif_bad_requests"] == 1; }, 20s));
  EXPECT_EQ(truth.sim_counters["onvif_requests"], 2);
  sim.stop();
  unlink(model_file.c_str());
}

TEST(OnvifSim, AnIndependentClientMovesTheHeadAndReadsItBack) {
  PTZ_REQUIRE_JS(kOnvifPackages);
  const std::string model_file = PTZ_SOURCE_DIR "/config/onvif/generic_ptz.yaml";
  const ptz::driver::OnvifModel model = ptz::driver::OnvifModel::load(model_file);
  const std::string password_file = "/tmp/ptz_onvif_password_" + std::to_string(getpid());
  std::ofstream(password_file) << "not-in-any-flag\n";
  setenv("ONVIF_PASSWORD", "not-in-any-flag", 1);  // the client's, as it reads it

  lcm::LCM lcm(ptz::test::kTestUrl);
  ASSERT_TRUE(lcm.good());
  Truth truth;
  lcm.subscribe("SIM_TRUTH", &Truth::onTruth, &truth);
  lcm.subscribe("PROCESS_STATUS_.*", &Truth::onStatus, &truth);
  const int port = 18560;
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                    PTZ_SOURCE_DIR "/config/sim_default.yaml", "--encoding", "jpeg", "--duration-s",
                    "120", "--onvif-port", std::to_string(port), "--onvif-model", model_file,
                    "--onvif-password-file", password_file, "--onvif-clock-offset-s", "3600",
                    "--status-period-s", "0.2"});
  ASSERT_TRUE(sim.started());
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return truth.count > 0; }, 30s))
      << "ptz-sim published no SIM_TRUTH";
  const double left_pan_before_rad = truth.last.left_head.pan_rad;

  // The right camera (port + 1): the left stays home.
  const double x = 0.5, y = -0.25, zoom = 0.6;
  const ptz::test::JsCheckResult r = ptz::test::runJsChecker(
      "onvif_client_check.js", {"--port", std::to_string(port + 1), "--user", "admin", "--x",
                                std::to_string(x), "--y", std::to_string(y), "--zoom",
                                std::to_string(zoom), "--tolerance", "0.005", "--timeout-s", "60"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_FALSE(r.json.is_null()) << r.err;
  std::printf("onvif client: %s\n", r.json.dump().c_str());
  EXPECT_EQ(r.json["profiles"][0]["token"], "profile_1");
  EXPECT_EQ(r.json["profiles"][0]["encoding"], "H264");
  EXPECT_EQ(r.json["deviceInformation"]["serialNumber"], "PTZSIM-RIGHT");
  EXPECT_NEAR(r.json["timeShiftMs"].get<double>(), 3600e3, 2000);
  const double got_x = r.json["status"]["x"], got_y = r.json["status"]["y"],
               got_zoom = r.json["status"]["zoom"];
  EXPECT_NEAR(got_x, x, 0.005);
  EXPECT_NEAR(got_y, y, 0.005);
  EXPECT_NEAR(got_zoom, zoom, 0.005);

  // The simulator's truth once settled: the model's degrees and zoom ratio for what was asked.
  constexpr double kDeg = M_PI / 180;
  ASSERT_TRUE(ptz::test::handleUntil(
      lcm,
      [&] {
        const auto& h = truth.last.right_head;
        return std::abs(h.pan_rad - model.panRad(x)) < 0.05 * kDeg &&
               std::abs(h.tilt_rad - model.tiltRad(y)) < 0.05 * kDeg &&
               std::abs(h.zoom - model.zoomRatio(zoom)) < 0.005;
      },
      30s))
      << "right head at pan " << truth.last.right_head.pan_rad / kDeg << " deg, tilt "
      << truth.last.right_head.tilt_rad / kDeg << " deg, zoom " << truth.last.right_head.zoom;
  const auto& h = truth.last.right_head;
  EXPECT_NEAR(h.pan_rad / kDeg, 85, 0.05);
  // What the client read back was the truth of its moment, in the model's map.
  EXPECT_NEAR(model.panRad(got_x) / kDeg, h.pan_rad / kDeg, 0.005 * 170 + 0.05);
  EXPECT_NEAR(truth.last.left_head.pan_rad, left_pan_before_rad, 1e-3);  // the other untouched

  // The rest of the PTZ and media operations through the package, on the same camera.
  const ptz::test::JsCheckResult e = ptz::test::runJsChecker(
      "onvif_client_check.js",
      {"--port", std::to_string(port + 1), "--user", "admin", "--x", "0.5", "--y", "-0.25",
       "--zoom", "0.6", "--exercise", "1", "--timeout-s", "60"});
  ASSERT_EQ(e.exit_code, 0) << e.err;
  ASSERT_TRUE(e.json.contains("exercise")) << e.err;
  const nlohmann::json& ex = e.json["exercise"];
  std::printf("onvif client exercise: %s\n", ex.dump().c_str());
  EXPECT_EQ(ex["nodes"], nlohmann::json::array({"node_1"}));
  EXPECT_EQ(ex["configurations"][0]["token"], "ptz_config_1");
  EXPECT_EQ(ex["absoluteX"]["max"], 1);
  EXPECT_EQ(ex["streamUri"].get<std::string>().rfind("rtsp://127.0.0.1:", 0), 0u);
  EXPECT_EQ(ex["presetsSet"], nlohmann::json::array({"door"}));
  EXPECT_EQ(ex["presetsLeft"], nlohmann::json::array());
  const double start_x = e.json["status"]["x"];
  // RelativeMove by -0.2; half a second of ContinuousMove at 0.5 then Stop: some way back up;
  // GotoPreset: where the preset was set (where the head was).
  const double relative_x = ex["afterRelativeMove"]["x"], stopped_x = ex["afterStop"]["x"];
  EXPECT_NEAR(relative_x, start_x - 0.2, 0.01);
  EXPECT_GT(stopped_x, relative_x + 0.02);
  EXPECT_LT(stopped_x, 0.99);  // stopped before the end of the range (the timeout is 60 s)
  EXPECT_NEAR(ex["afterGotoPreset"]["x"].get<double>(), start_x, 0.01);

  // A wrong password is refused and counted in ptz-sim's status.
  setenv("ONVIF_PASSWORD", "wrong", 1);
  const ptz::test::JsCheckResult refused = ptz::test::runJsChecker(
      "onvif_client_check.js",
      {"--port", std::to_string(port), "--user", "admin", "--x", "0", "--y", "0", "--zoom", "0"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_NE(refused.err.find("not Authorized"), std::string::npos) << refused.err;
  EXPECT_TRUE(ptz::test::handleUntil(
      lcm, [&] { return truth.sim_counters["onvif_auth_refused"] >= 1; }, 10s));
  EXPECT_GE(truth.sim_counters["onvif_requests"], 8);
  sim.stop();
  unlink(password_file.c_str());
}
