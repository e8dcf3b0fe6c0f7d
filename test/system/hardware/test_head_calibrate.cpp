// ptz-head-calibrate against ptz-sim's cheap ONVIF cameras (a slow GetStatus, moves that ignore
// speed, a zoom far from linear), started from the generic camera's model file whose zoom map is
// wrong: the model file it writes holds the cheap camera's map (pan and tilt within 0.5 %, the
// focal length within 2 % over the zoom range). Real processes, real HTTP/SOAP and LCM, realtime;
// the scene static, as the calibration asks.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "common/rig.hpp"
#include "ptz_driver/heads/onvif/head/onvif_model.hpp"
#include "ptz_driver/heads/visca/visca_model.hpp"
#include "support/child_process.hpp"
#include "support/focal_length_error.hpp"
#include "support/lcm_wait.hpp"
#include "support/step_test.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

const std::string kConfig = PTZ_SOURCE_DIR "/config/";
const std::string kUrl = ptz::test::kTestUrl;

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(HeadCalibrate, TheCheapOnvifCamerasMapIsMeasuredThroughTheirOnvifServers) {
  const std::string out = "/tmp/ptz_head_calibrate_" + std::to_string(::getpid()) + ".yaml";
  const std::string cheap = kConfig + "onvif/cheap_ptz.yaml";
  // A static scene (the calibration's condition): the paper's, its plant's dead time included.
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", kUrl, "--config", kConfig + "sim_paper.yaml",
                    "--clock", "realtime", "--onvif-port", "18100", "--onvif-model", cheap,
                    "--duration-s", "400"});
  const std::string log = "/tmp/ptz_head_calibrate_" + std::to_string(::getpid()) + ".log";
  ChildProcess calibrate(
      {PTZ_HEAD_CALIBRATE_BIN, "--lcm-url", kUrl, "--backend", "onvif", "--onvif-model",
       kConfig + "onvif/generic_ptz.yaml", "--onvif-left-url", "http://127.0.0.1:18100",
       "--onvif-right-url", "http://127.0.0.1:18101", "--output", out},
      log);
  const int code = calibrate.wait(std::chrono::seconds(280));
  ASSERT_EQ(code, 0) << "ptz-head-calibrate said:\n" << readFile(log);
  std::remove(log.c_str());
  const ptz::driver::OnvifModel truth = ptz::driver::OnvifModel::load(cheap);
  const ptz::driver::OnvifModel measured = ptz::driver::OnvifModel::load(out);
  const double pan_scale = (truth.pan_max_rad - truth.pan_min_rad) / 2;
  const double tilt_scale = (truth.tilt_max_rad - truth.tilt_min_rad) / 2;
  EXPECT_NEAR((measured.pan_max_rad - measured.pan_min_rad) / 2 / pan_scale, 1, 0.005);
  EXPECT_NEAR((measured.tilt_max_rad - measured.tilt_min_rad) / 2 / tilt_scale, 1, 0.005);
  const double worst = ptz::test::worstFocalLengthError(
      ptz::StereoRig::makeDefault(), 0, 1, 0.01, [&](double u) { return truth.zoomRatio(u); },
      [&](double u) { return measured.zoomRatio(u); });
  std::printf("pan %.4f %%, tilt %.4f %%, focal length worst %.3f %%\n",
              100 * ((measured.pan_max_rad - measured.pan_min_rad) / 2 / pan_scale - 1),
              100 * ((measured.tilt_max_rad - measured.tilt_min_rad) / 2 / tilt_scale - 1),
              100 * worst);
  ::unlink(out.c_str());
}

// A VISCA camera (ptz-sim as a Sony SRG-300 over VISCA-over-IP) whose model file is unknown: the
// calibration starts from a file of the same family with a third fewer units per degree and a
// linear zoom, and writes the SRG-300's map.
TEST(HeadCalibrate, AViscaCamerasMapIsMeasuredThroughItsViscaServer) {
  const std::string tmp = "/tmp/ptz_head_calibrate_visca_" + std::to_string(::getpid());
  const std::string srg300 = kConfig + "visca/sony_srg300.yaml";
  std::ofstream(tmp + "_guess.yaml")
      << "%YAML:1.0\n---\nname: \"an unknown VISCA camera\"\npan_nibbles: 5\n"
         "pan_units_per_deg: 34.0\ntilt_units_per_deg: 34.0\npan_min_deg: -170.0\n"
         "pan_max_deg: 170.0\ntilt_min_deg: -20.0\ntilt_max_deg: 90.0\npan_speed_max: 24\n"
         "tilt_speed_max: 23\nzoom_positions: [0, 16384]\nzoom_ratios: [1, 16]\n";
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", kUrl, "--config", kConfig + "sim_paper.yaml",
                    "--clock", "realtime", "--visca-port", "52395", "--visca-model", srg300,
                    "--duration-s", "400"});
  ChildProcess calibrate(
      {PTZ_HEAD_CALIBRATE_BIN, "--lcm-url", kUrl, "--backend", "visca_ip", "--visca-model",
       tmp + "_guess.yaml", "--left-port", "52395", "--right-port", "52396", "--zoom-max-units",
       "14000", "--output", tmp + ".yaml"},
      tmp + ".log");
  ASSERT_EQ(calibrate.wait(std::chrono::seconds(280)), 0) << "ptz-head-calibrate said:\n"
                                                          << readFile(tmp + ".log");
  const ptz::driver::ViscaModel truth = ptz::driver::ViscaModel::load(srg300);
  const ptz::driver::ViscaModel measured = ptz::driver::ViscaModel::load(tmp + ".yaml");
  EXPECT_NEAR(measured.pan_units_per_rad / truth.pan_units_per_rad, 1, 0.005);
  EXPECT_NEAR(measured.tilt_units_per_rad / truth.tilt_units_per_rad, 1, 0.005);
  const double worst = ptz::test::worstFocalLengthError(
      ptz::StereoRig::makeDefault(), 0, 14000, 100,
      [&](double u) { return truth.zoomRatio(static_cast<int>(u)); },
      [&](double u) { return measured.zoomRatio(static_cast<int>(u)); });
  std::printf("VISCA: pan %+.4f %%, tilt %+.4f %%, focal length worst %.3f %%\n",
              100 * (measured.pan_units_per_rad / truth.pan_units_per_rad - 1),
              100 * (measured.tilt_units_per_rad / truth.tilt_units_per_rad - 1), 100 * worst);
  for (const char* end : {"_guess.yaml", ".yaml", ".log"}) std::remove((tmp + end).c_str());
}

// A camera that refuses the password, and a rig whose frames never come: each fails within its
// timeout with the reason on stderr, the password not in it, and no model file written.
TEST(HeadCalibrate, ARefusedPasswordOrNoFramesFailsWithTheReason) {
  const std::string tmp = "/tmp/ptz_head_calibrate_refused_" + std::to_string(::getpid());
  std::ofstream(tmp + ".pw") << "not-the-password\n";
  ::setenv("PTZ_SIM_ONVIF_PASSWORD", "the-password", 1);
  const std::string generic = kConfig + "onvif/generic_ptz.yaml";
  {
    ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", kUrl, "--config", kConfig + "sim_default.yaml",
                      "--onvif-port", "18110", "--onvif-model", generic, "--duration-s", "60"});
    ChildProcess calibrate({PTZ_HEAD_CALIBRATE_BIN, "--lcm-url", kUrl, "--backend", "onvif",
                            "--onvif-model", generic, "--onvif-left-url", "http://127.0.0.1:18110",
                            "--onvif-right-url", "http://127.0.0.1:18111", "--onvif-password-file",
                            tmp + ".pw", "--move-timeout-s", "3", "--output", tmp + ".yaml"},
                           tmp + ".log");
    EXPECT_EQ(calibrate.wait(std::chrono::seconds(30)), 1);
  }
  ::unsetenv("PTZ_SIM_ONVIF_PASSWORD");
  const std::string refused = readFile(tmp + ".log");
  EXPECT_NE(refused.find("did not reach"), std::string::npos) << refused;
  EXPECT_NE(refused.find("NotAuthorized"), std::string::npos) << refused;
  EXPECT_EQ(refused.find("the-password"), std::string::npos) << "a password is never printed";
  EXPECT_NE(::access((tmp + ".yaml").c_str(), F_OK), 0) << "no model file from a failed run";
  {
    ChildProcess calibrate(
        {PTZ_HEAD_CALIBRATE_BIN, "--lcm-url", kUrl, "--backend", "onvif", "--onvif-model", generic,
         "--move-timeout-s", "2", "--output", tmp + ".yaml"},
        tmp + ".log");
    EXPECT_EQ(calibrate.wait(std::chrono::seconds(30)), 1);
  }
  const std::string silent = readFile(tmp + ".log");
  EXPECT_NE(silent.find("no usable STEREO_FRAME for 2 s"), std::string::npos) << silent;
  std::remove((tmp + ".pw").c_str());
  std::remove((tmp + ".log").c_str());
}

// The rest of a head's model, its response: a step through ptz-driver's onvif backend logged as
// a user logs it, fitted by ptz-identify (the camera: the paper's plant, K 1, T 0.24 s, dead time
// 0.1 s; what the wire adds shows as dead time).
TEST(HeadCalibrate, AnOnvifCamerasResponseIsIdentifiedFromALoggedStep) {
  const std::string path = "/tmp/ptz_onvif_step_" + std::to_string(::getpid()) + ".lcmlog";
  const std::string model = kConfig + "onvif/generic_ptz.yaml";
  {
    lcm::LCM lcm(kUrl);
    lcm::LogFile log(path, "w");
    ASSERT_TRUE(log.good());
    ptz::test::StepTest t{&lcm, &log};
    ChildProcess driver({PTZ_DRIVER_BIN, "--lcm-url", kUrl, "--backend", "onvif", "--onvif-model",
                         model, "--onvif-left-url", "http://127.0.0.1:18120", "--onvif-right-url",
                         "http://127.0.0.1:18121", "--onvif-status-rate-hz", "50",
                         "--max-setpoint-rate", "100"});
    ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", kUrl, "--config", kConfig + "sim_paper.yaml",
                      "--clock", "realtime", "--encoding", "jpeg", "--onvif-port", "18120",
                      "--onvif-model", model, "--duration-s", "4"});
    t.subscribe();
    ptz::test::handleUntil(
        lcm, [&] { return sim.wait(0ms) >= 0; }, 60s);
    ptz::test::drain(lcm, 300ms);
    ASSERT_GT(t.events, 200);
  }
  const ptz::test::Identified fit = ptz::test::identify(PTZ_IDENTIFY_BIN, path);
  std::remove(path.c_str());
  ASSERT_TRUE(fit.ok) << fit.text;
  std::printf("%s", fit.text.c_str());
  EXPECT_NEAR(fit.K, 1.0, 0.03);
  EXPECT_NEAR(fit.T_s, 0.24, 0.1 * 0.24);
  EXPECT_GT(fit.tau_s, 0.1 - 0.01);  // never less than the camera's own
  EXPECT_LT(fit.tau_s, 0.2);         // and the wire adds tens of ms at most
}

}  // namespace
