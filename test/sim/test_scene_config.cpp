// A scenario's objects read from a config file, and a bad one named.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>

#include "common/config.hpp"
#include "sim/scene/scene.hpp"
#include "support/run_program.hpp"

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = std::string(::testing::TempDir()) + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// The scene of a config file, read as ptz-sim reads its sections.
ptz::sim::Scene sceneOf(const std::string& path) {
  cv::FileStorage fs = ptz::openForRead(path, "config file");
  return ptz::sim::Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"], path);
}

}  // namespace

TEST(SceneConfig, ObjectsAreReadAndBadOnesNamed) {
  const std::string cfg = writeTemp(
      "scene.yaml",
      "%YAML:1.0\n---\nobjects:\n"
      "  - { name: \"a\", class: \"red_ball\", shape: \"sphere\", radius_m: 0.1,\n"
      "      color_bgr: [0, 0, 200], trajectory: \"circle\", centre_m: [0, 0, 3],\n"
      "      amplitude_m: [1, 0, 1], period_s: 10 }\n"
      "  - { name: \"b\", class: \"green_box\", shape: \"box\", half_extents_m: [0.1, 0.2, 0.3],\n"
      "      color_bgr: [0, 200, 0], yaw_rad: 0.5, yaw_rate_rad_s: -0.25 }\n");
  const auto scene = sceneOf(cfg);
  ASSERT_EQ(scene.objects.size(), 2u);
  EXPECT_EQ(scene.objects[1].class_name, "green_box");
  // The box turns from 0.5 rad at -0.25 rad/s about the head's y axis; a sphere has no yaw.
  EXPECT_NEAR(scene.objects[1].yaw(2.0), 0.0, 1e-12);
  EXPECT_NEAR(scene.objects[1].yaw(4.0), -0.5, 1e-12);
  const Eigen::Vector3d x = scene.objects[1].rotationHeadObject(0) * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(x.x(), std::cos(0.5), 1e-12);
  EXPECT_NEAR(x.z(), -std::sin(0.5), 1e-12);
  EXPECT_EQ(scene.objects[0].yaw(3.0), 0.0);
  // A circle of radius 1 m in x/z about (0, 0, 3): a quarter period later it is at +z.
  EXPECT_NEAR(scene.objects[0].trajectory.position(0).x(), 1.0, 1e-12);
  EXPECT_NEAR(scene.objects[0].trajectory.position(2.5).z(), 4.0, 1e-12);

  const std::string bad = writeTemp("bad_scene.yaml",
                                    "%YAML:1.0\n---\nobjects:\n"
                                    "  - { name: \"a\", class: \"red_ball\", shape: \"cone\", "
                                    "radius_m: 0.1, color_bgr: [0, 0, 1] }\n");
  try {
    sceneOf(bad);
    FAIL() << "a cone is no shape of ours";
  } catch (const ptz::ConfigError& e) {
    const std::string err = e.what();
    EXPECT_NE(err.find("objects[0]"), std::string::npos) << err;
    EXPECT_NE(err.find("shape"), std::string::npos) << err;
  }
}

// Every level refuses what it does not know, and values out of range, naming path and value.
TEST(SceneConfig, UnknownFieldsAndValuesOutOfRangeAreRefusedWithTheirPath) {
  const std::string ball =
      "  - { name: \"a\", class: \"red_ball\", shape: \"sphere\", radius_m: 0.1, "
      "color_bgr: [0, 0, 200]";
  struct Case {
    std::string yaml, expected;
  };
  const std::vector<Case> cases = {
      {"objects:\n" + ball + ", speed_mps: 2 }\n", "objects[0].speed_mps: unknown field"},
      {"objects:\n" + ball + ", yaw_rad: 1 }\n", "objects[0].yaw_rad: unknown field"},
      {"objects:\n" + ball + ", yaw_rate_rad_s: 1 }\n", "objects[0].yaw_rate_rad_s: unknown field"},
      {"objects:\n  - { name: \"b\", class: \"green_box\", shape: \"box\", "
       "half_extents_m: [0.1, 0.1, 0.1], color_bgr: [0, 200, 0], yaw_rate_rad_s: 30 }\n",
       "objects[0].yaw_rate_rad_s: must be within -20 .. 20, got '30'"},
      {"scene: { floor_heigth_m: 1.4 }\n", "scene.floor_heigth_m: unknown field"},
      {"chessboard: { inner_cols: 9, inner_rows: 6, square_m: 0.1, centre: [0, 0, 2] }\n",
       "chessboard.centre: unknown field"},
      {"scene: 3\n", "scene: must be a map of fields, got '3'"},
      {"objects:\n" + ball + ", period_s: -2 }\n", "objects[0].period_s: must be > 0, got '-2'"},
      {"objects:\n  - { name: \"a\", class: \"b\", shape: \"sphere\", radius_m: 0.1, "
       "color_bgr: [0, 256, 1] }\n",
       "objects[0].color_bgr[1]: must be within 0 .. 255, got '256'"},
      {"objects:\n" + ball + ", textured: 2 }\n",
       "objects[0].textured: must be within 0 .. 1, got '2'"},
      {"scene: { backdrop_distance_m: 0.2 }\n",
       "scene.backdrop_distance_m: must be > 0.5, got '0.2'"},
      {"chessboard: { inner_cols: 9, inner_rows: 1, square_m: 0.1 }\n",
       "chessboard.inner_rows: must be within 2 .. 1000, got '1'"},
  };
  for (const auto& c : cases) {
    const std::string path = writeTemp("unknown_scene.yaml", "%YAML:1.0\n---\n" + c.yaml);
    try {
      sceneOf(path);
      ADD_FAILURE() << "accepted: " << c.yaml;
    } catch (const ptz::ConfigError& e) {
      const std::string expected = path + ", " + c.expected;  // then the known fields, if any
      EXPECT_EQ(std::string(e.what()).substr(0, expected.size()), expected) << c.yaml;
    }
  }
}

// ptz-sim itself (memq://, no network): bad settings stop it with exit 2, the source, the
// parameter and the value on one line.
TEST(SimSettings, BadValuesNameTheirSourceParameterAndValue) {
  auto sim = [](std::vector<std::string> args) {
    args.insert(args.begin(), {PTZ_SIM_BIN, "--lcm-url", "memq://", "--frames", "1"});
    return ptz::test::runProgram(args);
  };
  const std::string cfg = writeTemp("sim_bad.yaml", "%YAML:1.0\n---\nframe_rate_hz: 0\n");
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--noise-sigma", "-1"},
       "flag --noise-sigma: parameter 'noise_sigma' must be within 0 .. 255, got '-1'"},
      {{"--config", cfg},
       "config file '" + cfg + "': parameter 'frame_rate_hz' must be within 0.1 .. 1000, got '0'"},
      {{"--dead-time-s", "-1"},
       "flag --dead-time-s: parameter 'dead_time_s' must be within 0 .. 60, got '-1'"},
      {{"--zoom-min", "5", "--zoom-max", "2"},
       "parameter 'zoom_min' = 5 (flag --zoom-min) must be below parameter 'zoom_max' = 2 (flag "
       "--zoom-max)"},
      {{"--clock", "sundial"},
       "flag --clock: parameter 'clock' must be realtime or lockstep, got 'sundial'"},
  };
  for (const auto& [args, expected] : cases) {
    const auto r = sim(args);
    EXPECT_EQ(r.exit_code, 2) << expected;
    EXPECT_EQ(r.err, "ptz-sim: " + expected + "\n");
  }
  const std::string objects = writeTemp(
      "sim_objects.yaml",
      "%YAML:1.0\n---\nobjects:\n  - { name: \"a\", class: \"red_ball\", shape: \"sphere\", "
      "radius_m: 0.1, color_bgr: [0, 0, 200], speed_mps: 2 }\n");
  const auto r = sim({"--config", objects});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(
      r.err.rfind("ptz-sim: config file '" + objects + "', objects[0].speed_mps: unknown field", 0),
      0u)
      << r.err;
}

// ptz-sim's ONVIF cameras: what is missing, excluded or unreadable stops it with exit 2 and one
// line; the password is never echoed.
TEST(SimSettings, OnvifSettingsAreCheckedAndThePasswordNeverShown) {
  auto sim = [](std::vector<std::string> args) {
    args.insert(args.begin(), {PTZ_SIM_BIN, "--lcm-url", "memq://", "--frames", "1"});
    return ptz::test::runProgram(args);
  };
  const std::string generic = PTZ_SOURCE_DIR "/config/onvif/generic_ptz.yaml";
  const std::string bad_model = writeTemp(
      "onvif_bad.yaml",
      "%YAML:1.0\n---\nname: \"x\"\nmanufacturer: \"m\"\nmodel: \"m\"\npan_min_deg: -10\n"
      "pan_max_deg: 10\ntilt_min_deg: -10\ntilt_max_deg: 10\npan_tilt_speed_max_deg_s: 10\n"
      "zoom_normalised: [0.1, 1]\nzoom_ratios: [1, 2]\n");
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--onvif-port", "18000"},
       "parameter 'onvif_port' needs 'onvif_model' (an ONVIF model file)"},
      {{"--onvif-port", "18000", "--onvif-model", generic, "--visca-port", "18002", "--visca-model",
        PTZ_SOURCE_DIR "/config/visca/sony_srg300.yaml"},
       "parameters 'onvif_port' and 'visca_port' exclude each other (one plant)"},
      {{"--onvif-port", "18000", "--onvif-model", bad_model},
       "ONVIF model file '" + bad_model + "', zoom_normalised: must run from 0 to 1"},
      {{"--onvif-port", "18000", "--onvif-model", generic, "--onvif-password-file",
        "/nonexistent/onvif_password"},
       "ONVIF password file '/nonexistent/onvif_password': cannot be read"},
  };
  for (const auto& [args, expected] : cases) {
    const auto r = sim(args);
    EXPECT_EQ(r.exit_code, 2) << expected;
    EXPECT_EQ(r.err, "ptz-sim: " + expected + "\n");
  }
  // A run with a password (a port of its own: this test is not in a private network).
  const std::string password_file = writeTemp("onvif_password", "p4ss-w0rd-never-shown\n");
  const auto r = sim({"--onvif-port", std::to_string(20000 + getpid() % 20000), "--onvif-model",
                      generic, "--onvif-password-file", password_file});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.find("p4ss"), std::string::npos);
  EXPECT_EQ(r.err.find("p4ss"), std::string::npos);
}
