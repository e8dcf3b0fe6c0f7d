// The paper's loop run by the real processes in lockstep (ptz-sim + ptz-detect + ptz-control in
// paper mode) just inside and just outside the delay that ptz-stability predicts for the sampled
// loop: the oscillation decays 3 % below it and grows 3 % above it, at 30 and at 60 Hz.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>

#include "common/transport/transport.hpp"
#include "control/controller/pointing.hpp"
#include "control/stability/stability.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"
#include "support/step_test.hpp"

using namespace std::chrono_literals;
using ptz::test::ChildProcess;

namespace {

struct Recorder {
  std::vector<double> pan;  // left pan at each frame's capture
  std::map<std::string, int> up;
  void onTruth(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::sim_truth_t* m) {
    pan.push_back(m->left_head.pan_rad);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    up[m->process] = 1;
  }
};

// A small step (the ball 0.06 rad off the axis) keeps a growing oscillation in view.
const Eigen::Vector3d kBall(0.18, 0.0, 3.0);

// The paper preset with the ball moved to kBall.
std::string scenario() {
  std::ifstream in(PTZ_SOURCE_DIR "/config/sim_paper.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string from = "centre_m: [0.5, 0.0, 3.0]";
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << "config/sim_paper.yaml changed its ball";
  if (pos != std::string::npos) {
    text.replace(pos, from.size(),
                 "centre_m: [" + std::to_string(kBall.x()) + ", " + std::to_string(kBall.y()) +
                     ", " + std::to_string(kBall.z()) + "]");
  }
  const std::string path = std::string(::testing::TempDir()) + "/sweep_paper.yaml";
  std::ofstream(path) << text;
  return path;
}

// Runs the loop for duration_s of sim time; returns the early and late oscillation envelopes.
std::pair<double, double> runPaperLoop(double tau_s, double fps, double duration_s) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Recorder r;
  lcm.subscribe("SIM_TRUTH", &Recorder::onTruth, &r);
  lcm.subscribe("PROCESS_STATUS_.*", &Recorder::onStatus, &r);
  ChildProcess detect({PTZ_DETECT_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                       PTZ_SOURCE_DIR "/config/detect_default.yaml"});
  ChildProcess control({PTZ_CONTROL_BIN, "--lcm-url", ptz::test::kTestUrl, "--config",
                        PTZ_SOURCE_DIR "/config/control_paper.yaml"});
  ptz::test::handleUntil(
      lcm, [&] { return r.up["ptz-detect"] && r.up["ptz-control"]; }, 20s);
  const int frames = static_cast<int>(duration_s * fps);
  ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--config", scenario(),
                    "--dead-time-s", std::to_string(tau_s), "--frame-rate-hz", std::to_string(fps),
                    "--frames", std::to_string(frames), "--lockstep-timeout-ms", "3000"});
  ptz::test::handleUntil(
      lcm, [&] { return sim.wait(0ms) >= 0; }, 180s);
  ptz::test::drain(lcm, 300ms);
  EXPECT_EQ(static_cast<int>(r.pan.size()), frames);
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  double target = 0, tilt = 0;
  ptz::control::aimAt(rig, ptz::Side::kLeft, kBall, 1.0, ptz::control::imageCentre(rig.left),
                      &target, &tilt);
  const double final_value = 1.7 / 2.7 * target;
  auto envelope = [&](double from_s, double to_s) {
    double m = 0;
    for (size_t k = static_cast<size_t>(from_s * fps); k < r.pan.size() && k < to_s * fps; ++k) {
      m = std::max(m, std::abs(r.pan[k] - final_value));
    }
    return m;
  };
  return {envelope(0.25 * duration_s, 0.5 * duration_s), envelope(0.75 * duration_s, duration_s)};
}

}  // namespace

TEST(StabilitySweep, TheRealLoopTurnsUnstableWhereTheSampledAnalysisSays) {
  for (double fps : {30.0, 60.0}) {
    const double tau_max = ptz::control::sampledTauMax({1.7, 0.24, 0.0}, fps);
    const auto inside = runPaperLoop(0.97 * tau_max, fps, 8.0);
    const auto outside = runPaperLoop(1.03 * tau_max, fps, 8.0);
    std::printf(
        "%g Hz: tau_max %.4f s; at 97 %%: envelope %.4f -> %.4f rad; at 103 %%: %.4f -> "
        "%.4f rad\n",
        fps, tau_max, inside.first, inside.second, outside.first, outside.second);
    EXPECT_LT(inside.second, inside.first) << fps << " Hz, 3 % below tau_max";
    EXPECT_GT(outside.second, outside.first) << fps << " Hz, 3 % above tau_max";
  }
}

TEST(Identify, RecoversTheSimulatorsAxisFromALoggedStepTest) {
  const std::string path = std::string(::testing::TempDir()) + "/step_test.lcmlog";
  {
    lcm::LCM lcm(ptz::test::kTestUrl);
    lcm::LogFile log(path, "w");
    ASSERT_TRUE(log.good());
    ptz::test::StepTest t{&lcm, &log};
    t.subscribe();
    ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--clock", "lockstep",
                      "--frames", "90", "--encoding", "jpeg", "--pan-gain", "0.9",
                      "--pan-time-constant-s", "0.3", "--dead-time-s", "0.15", "--pan-max-rate",
                      "100", "--lockstep-timeout-ms", "3000"});
    ptz::test::handleUntil(
        lcm, [&] { return sim.wait(0ms) >= 0; }, 60s);
    ptz::test::drain(lcm, 300ms);
    ASSERT_GT(t.events, 300);
  }
  const ptz::test::Identified fit = ptz::test::identify(PTZ_IDENTIFY_BIN, path);
  ASSERT_TRUE(fit.ok) << fit.text;
  std::printf("%s", fit.text.c_str());
  EXPECT_NEAR(fit.K, 0.9, 0.03 * 0.9);
  EXPECT_NEAR(fit.T_s, 0.3, 0.03 * 0.3);
  EXPECT_NEAR(fit.tau_s, 0.15, 0.03 * 0.15);
}
