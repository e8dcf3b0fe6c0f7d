// A scenario's objects read from a config file, and a bad one named.
#include <gtest/gtest.h>

#include <fstream>

#include "common/config.hpp"
#include "sim/scene.hpp"

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
      "      color_bgr: [0, 200, 0] }\n");
  const auto scene = sceneOf(cfg);
  ASSERT_EQ(scene.objects.size(), 2u);
  EXPECT_EQ(scene.objects[1].class_name, "green_box");
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
