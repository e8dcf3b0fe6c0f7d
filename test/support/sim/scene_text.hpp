// What the simulator's tests share: a scene's light read from a config text, as ptz-sim reads
// it, and a scene of one red ball.
#pragma once

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "common/config.hpp"
#include "sim/scene/scene.hpp"

namespace ptz::test {

// The `light` map light_map (YAML flow text) of a scene section, through Scene::fromConfig.
inline sim::Light lightFromText(const std::string& light_map) {
  const std::string path = std::string(::testing::TempDir()) + "/light.yaml";
  std::ofstream(path) << "%YAML:1.0\n---\nscene:\n  light: " << light_map << "\n";
  cv::FileStorage fs = openForRead(path, "config file");
  return sim::Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"], path).light;
}

// What lightFromText says of light_map: the ConfigError's message, or "accepted".
inline std::string lightErrorOf(const std::string& light_map) {
  try {
    lightFromText(light_map);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

// A saturated red ball of radius 0.1 m at (x_m, 0, 3) in the head frame.
inline sim::Scene redBallScene(double x_m) {
  sim::Scene scene;
  scene.objects.resize(1);
  scene.objects[0].color_bgr = {0, 0, 255};
  scene.objects[0].radius_m = 0.1;
  scene.objects[0].trajectory.centre_m = Eigen::Vector3d(x_m, 0, 3);
  return scene;
}

}  // namespace ptz::test
