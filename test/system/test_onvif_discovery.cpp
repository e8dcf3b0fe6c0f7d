// WS-Discovery over real UDP multicast in a private network namespace: ptz-driver --discover finds
// ptz-sim's two ONVIF cameras (their XAddrs, and with the password their RTSP streams and the
// ptz-camera flag); an independent client (npm `onvif`'s Discovery.probe) finds them too; hostile
// probes to ptz-sim and hostile answers to the prober are dropped and counted, and both go on.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <map>
#include <string>
#include <thread>

#include "ptz_driver/emulators/onvif/onvif_discovery.hpp"
#include "ptz_driver/heads/onvif/discovery/ws_discovery.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/mcap_check.hpp"
#include "support/run_program.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

constexpr const char* kPassword = "discovery-secret-7";

struct SimWatch {
  int64_t truths = 0;
  std::map<std::string, int64_t> counters;
  void onTruth(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::sim_truth_t*) {
    ++truths;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    if (m->process != "ptz-sim") return;
    for (const auto& c : m->counters) counters[c.name] = c.value;
  }
};

// ptz-sim serving ONVIF at port and port + 1 (password from a file), up once it rendered.
class SimCameras {
 public:
  SimCameras(int port, const std::string& password_file)
      : lcm_(ptz::test::kTestUrl),
        sim_({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
              PTZ_SOURCE_DIR "/config/sim_default.yaml", "--encoding", "jpeg", "--duration-s",
              "120", "--onvif-port", std::to_string(port), "--onvif-model",
              PTZ_SOURCE_DIR "/config/onvif/generic_ptz.yaml", "--onvif-password-file",
              password_file, "--status-period-s", "0.2"}) {
    lcm_.subscribe("SIM_TRUTH", &SimWatch::onTruth, &watch_);
    lcm_.subscribe("PROCESS_STATUS_.*", &SimWatch::onStatus, &watch_);
  }
  // The responder starts before the first frame.
  bool up() {
    return sim_.started() && ptz::test::handleUntil(
                                 lcm_, [&] { return watch_.truths > 0; }, 30s);
  }
  bool counterReaches(const std::string& name, int64_t value) {
    return ptz::test::handleUntil(
        lcm_, [&] { return watch_.counters[name] == value; }, 20s);
  }
  int64_t counter(const std::string& name) { return watch_.counters[name]; }
  bool running() { return sim_.running(); }
  void stop() { sim_.stop(); }

 private:
  lcm::LCM lcm_;
  SimWatch watch_;
  ChildProcess sim_;
};

std::string passwordFile() {
  const std::string path = "/tmp/ptz_discovery_password_" + std::to_string(getpid());
  std::ofstream(path) << kPassword << "\n";
  return path;
}

int udpSocket() {
  return ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
}

void sendTo(int fd, const std::string& bytes, const char* host, int port) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(port));
  ::inet_pton(AF_INET, host, &to.sin_addr);
  ASSERT_EQ(
      ::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to),
      static_cast<ssize_t>(bytes.size()));
}

std::string xaddr(int port) {
  return "http://127.0.0.1:" + std::to_string(port) + "/onvif/device_service";
}

}  // namespace

TEST(OnvifDiscovery, PtzDriverFindsBothSimCamerasAndTheirStreams) {
  const int port = 18600;
  const std::string pw = passwordFile();
  SimCameras sim(port, pw);
  ASSERT_TRUE(sim.up()) << "ptz-sim published no SIM_TRUTH";

  const auto t0 = std::chrono::steady_clock::now();
  const ptz::test::ProgramResult r =
      ptz::test::runProgram({PTZ_DRIVER_BIN, "--discover", "--discover-timeout-ms", "1000",
                             "--onvif-user", "admin", "--onvif-password-file", pw});
  std::printf("ptz-driver --discover (%.2f s):\n%s%s",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
              r.out.c_str(), r.err.c_str());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // One line per camera with its endpoint, XAddrs and scopes; then its stream and the flag.
  const std::string stream = "rtsp://127.0.0.1:554/profile_1";
  for (int p : {port, port + 1}) {
    char endpoint[64];
    std::snprintf(endpoint, sizeof endpoint, "urn:uuid:5054a5a3-0000-4000-8000-%012x", p);
    const std::string name = p == port ? "ptz-sim left" : "ptz-sim right";
    const std::string line = std::string("camera ") + endpoint + " xaddrs " + xaddr(p) + " name '" +
                             name + "' hardware 'SimDome-1'\n";
    const size_t at = r.out.find(line);
    ASSERT_NE(at, std::string::npos) << line;
    const std::string listed = line + "  profile profile_1 name 'profile_1' 640x480 ptz stream " +
                               stream + "\n" + "    ptz-camera --left-source " + stream +
                               "  # or --right-source: this camera's side\n";
    EXPECT_EQ(r.out.substr(at, listed.size()), listed);
  }
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 6) << r.out;
  EXPECT_EQ(r.out.find(kPassword), std::string::npos);
  EXPECT_EQ(r.err.find(kPassword), std::string::npos);
  EXPECT_TRUE(sim.counterReaches("onvif_probes_answered", 1));
  EXPECT_EQ(sim.counter("onvif_probes_dropped"), 0);

  // A wrong password: the cameras are found, their streams not, and stderr names each.
  const std::string wrong = pw + "_wrong";
  std::ofstream(wrong) << "not-the-password\n";
  const ptz::test::ProgramResult w =
      ptz::test::runProgram({PTZ_DRIVER_BIN, "--discover", "--discover-timeout-ms", "1000",
                             "--onvif-password-file", wrong});
  EXPECT_EQ(w.exit_code, 4) << w.err;
  EXPECT_NE(w.out.find("camera "), std::string::npos);
  EXPECT_EQ(w.out.find("rtsp://"), std::string::npos);
  EXPECT_NE(w.err.find(xaddr(port) + "): GetCapabilities: SOAP fault env:Sender ter:NotAuthorized"),
            std::string::npos)
      << w.err;
  EXPECT_EQ(w.err.find("not-the-password"), std::string::npos);
  sim.stop();
  unlink(pw.c_str());
  unlink(wrong.c_str());
}

TEST(OnvifDiscovery, NothingAnsweringIsAnErrorNamingIt) {
  const ptz::test::ProgramResult r =
      ptz::test::runProgram({PTZ_DRIVER_BIN, "--discover", "--discover-timeout-ms", "200"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("WS-Discovery: no ONVIF camera answered within 200 ms"), std::string::npos)
      << r.err;
}

TEST(OnvifDiscovery, AnIndependentClientFindsBothSimCameras) {
  PTZ_REQUIRE_JS(std::vector<std::string>{"onvif"});
  const int port = 18610;
  const std::string pw = passwordFile();
  SimCameras sim(port, pw);
  ASSERT_TRUE(sim.up()) << "ptz-sim published no SIM_TRUTH";
  const ptz::test::JsCheckResult r = ptz::test::runJsChecker(
      "onvif_discovery_check.js", {"--timeout-ms", "1000", "--expect", "2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("npm onvif Discovery.probe: %s\n", r.json.dump().c_str());
  ASSERT_EQ(r.json["devices"].size(), 2u);
  EXPECT_TRUE(r.json["errors"].empty());
  for (int i = 0; i < 2; ++i) {
    const auto& d = r.json["devices"][i];
    EXPECT_EQ(d["xaddrs"], nlohmann::json::array({xaddr(port + i)}));
    EXPECT_NE(std::find(d["types"].begin(), d["types"].end(), "dn:NetworkVideoTransmitter"),
              d["types"].end());
    EXPECT_NE(std::find(d["scopes"].begin(), d["scopes"].end(),
                        std::string("onvif://www.onvif.org/name/ptz-sim%20") +
                            (i == 0 ? "left" : "right")),
              d["scopes"].end());
  }
  EXPECT_TRUE(sim.counterReaches("onvif_probes_answered", 1));
  sim.stop();
  unlink(pw.c_str());
}

TEST(OnvifDiscovery, HostileProbesAreDroppedAndCountedAndPtzSimAnswersAfter) {
  const int port = 18620;
  const std::string pw = passwordFile();
  SimCameras sim(port, pw);
  ASSERT_TRUE(sim.up()) << "ptz-sim published no SIM_TRUTH";
  const std::string probe_head =
      "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\" "
      "xmlns:a=\"http://schemas.xmlsoap.org/ws/2004/08/addressing\" "
      "xmlns:d=\"http://schemas.xmlsoap.org/ws/2005/04/discovery\"><s:Header>";
  const std::string probe_action =
      "<a:Action>http://schemas.xmlsoap.org/ws/2005/04/discovery/Probe</a:Action>";
  const std::string id = "<a:MessageID>urn:uuid:1</a:MessageID>";
  const std::vector<std::string> malformed = {
      std::string("\x00\x01\xff garbage", 11),
      std::string(20000, '<'),  // over 16 kB: dropped unread
      "<?xml version=\"1.0\"?><!DOCTYPE s [<!ENTITY a \"aaaaaaaa\"><!ENTITY b \"&a;&a;&a;\">]>" +
          probe_head + probe_action + id +
          "</s:Header><s:Body><d:Probe>&b;</d:Probe></s:Body>"
          "</s:Envelope>",
      probe_head + "<a:Action>http://schemas.xmlsoap.org/ws/2005/04/discovery/Hello</a:Action>" +
          id + "</s:Header><s:Body><d:Probe/></s:Body></s:Envelope>",
      probe_head + probe_action + "</s:Header><s:Body><d:Probe/></s:Body></s:Envelope>",
      probe_head + probe_action + id + "</s:Header><s:Body><d:Probe>" + std::string(100, '<'),
  };
  const std::string printers = probe_head + probe_action + id +
                               "</s:Header><s:Body><d:Probe><d:Types xmlns:p=\"urn:printers\">"
                               "p:Printer</d:Types></d:Probe></s:Body></s:Envelope>";
  const int fd = udpSocket();
  ASSERT_GE(fd, 0);
  for (const std::string& m : malformed) sendTo(fd, m, "239.255.255.250", 3702);
  sendTo(fd, printers, "239.255.255.250", 3702);
  ::close(fd);
  // One socket in order: a Probe answered after them means they were all read.
  ptz::onvif::DiscoveryOptions o;
  o.timeout_ms = 1000;
  const auto found = ptz::onvif::discover(o);
  ASSERT_TRUE(found) << found.error();
  ASSERT_EQ(found->devices.size(), 2u);
  EXPECT_EQ(found->devices[0].xaddrs.at(0), xaddr(port));
  EXPECT_EQ(found->devices[1].xaddrs.at(0), xaddr(port + 1));
  EXPECT_TRUE(sim.counterReaches("onvif_probes_dropped", static_cast<int64_t>(malformed.size())));
  EXPECT_EQ(sim.counter("onvif_probes_ignored"), 1);
  EXPECT_EQ(sim.counter("onvif_probes_answered"), 1);
  EXPECT_TRUE(sim.running());
  sim.stop();
  unlink(pw.c_str());
}

TEST(OnvifDiscovery, HostileAnswersAreDroppedAndCountedAndTheGoodOneKept) {
  // A camera of the test's own on the group: it answers the Probe with a datagram too large, one
  // for another Probe, garbage, a good one and the good one again.
  const ptz::driver::DiscoveredCamera cam{"urn:uuid:00000000-1111-4000-8000-000000000001",
                                          "http://127.0.0.1:18630/onvif/device_service", "fake",
                                          "Fake-1"};
  const int fd = udpSocket();
  ASSERT_GE(fd, 0);
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(3702);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ip_mreq m{};
  ::inet_pton(AF_INET, "239.255.255.250", &m.imr_multiaddr);
  ASSERT_EQ(::setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof m), 0);
  std::string probe_id;
  std::thread camera([&] {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 10000) != 1) return;
    char buf[4096];
    sockaddr_in from{};
    socklen_t len = sizeof from;
    const ssize_t n = ::recvfrom(fd, buf, sizeof buf, 0, reinterpret_cast<sockaddr*>(&from), &len);
    if (n <= 0) return;
    const ptz::driver::ProbeRead probe = ptz::driver::readProbe(std::string_view(buf, n));
    probe_id = probe.message_id;
    const std::string good = ptz::driver::probeMatchesMessage(cam, probe.message_id, "urn:uuid:2");
    const std::string large = good + std::string(40000, ' ');
    for (const std::string& reply :
         {large, ptz::driver::probeMatchesMessage(cam, "urn:uuid:another", "urn:uuid:3"),
          std::string("<s:Envelope>garbage"), good, good}) {
      ::sendto(fd, reply.data(), reply.size(), 0, reinterpret_cast<sockaddr*>(&from), len);
    }
  });
  ptz::onvif::DiscoveryOptions o;
  o.timeout_ms = 1000;
  const auto found = ptz::onvif::discover(o);
  camera.join();
  ::close(fd);
  ASSERT_TRUE(found) << found.error();
  EXPECT_EQ(probe_id, found->message_id);
  ASSERT_EQ(found->devices.size(), 1u);
  EXPECT_EQ(found->devices[0].endpoint, cam.endpoint);
  EXPECT_EQ(found->devices[0].xaddrs, std::vector<std::string>{cam.xaddr});
  EXPECT_EQ(ptz::onvif::scopeValue(found->devices[0].scopes, "hardware"), "Fake-1");
  const ptz::onvif::DiscoveryCounters& c = found->counters;
  EXPECT_EQ(c.replies, 5);
  EXPECT_EQ(c.oversize, 1);
  EXPECT_EQ(c.wrong_relates_to, 1);
  EXPECT_EQ(c.malformed, 1);
  EXPECT_EQ(c.matches, 2);
  EXPECT_EQ(c.duplicates, 1);
  EXPECT_EQ(found->problems.size(), 3u);
}
