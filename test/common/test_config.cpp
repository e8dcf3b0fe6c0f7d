// Params: config file values, flag overrides and errors that name the file, field or flag.
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

ptz::Params makeParams() {
  ptz::Params p("prog", "test");
  p.add("rate_hz", 30.0, "Hz", "rate");
  p.add("frames", 10, "", "frames");
  p.add("verbose", false, "verbose");
  p.add("mode", "fast", "mode");
  p.addSection("objects", "objects");
  return p;
}

std::string parseError(ptz::Params& p, std::vector<std::string> args) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  try {
    p.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const ptz::ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Params, FlagsOverrideTheConfigFile) {
  const std::string cfg =
      writeTemp("params.yaml", "%YAML:1.0\n---\nrate_hz: 60.0\nframes: 5\nmode: \"slow\"\n");
  ptz::Params p = makeParams();
  EXPECT_EQ(parseError(p, {"prog", "--config", cfg, "--frames=7", "--verbose"}), "");
  EXPECT_DOUBLE_EQ(p.getDouble("rate_hz"), 60.0);
  EXPECT_EQ(p.getInt("frames"), 7);
  EXPECT_TRUE(p.getBool("verbose"));
  EXPECT_EQ(p.getString("mode"), "slow");
  // Dashes and underscores alike.
  ptz::Params q = makeParams();
  EXPECT_EQ(parseError(q, {"prog", "--rate-hz", "12.5"}), "");
  EXPECT_DOUBLE_EQ(q.getDouble("rate_hz"), 12.5);
  // The README tables (--help-markdown): parameters as declared, then sections; a '|' escaped.
  ptz::Params t("prog", "test");
  t.add("rate_hz", 30.0, "Hz", "rate");
  t.addSection("objects", "shape: sphere|box");
  t.addSection("chessboard", "board");
  EXPECT_EQ(
      t.markdownTable(),
      "| parameter | unit | default | meaning |\n|---|---|---|---|\n"
      "| `config` |  |  | YAML config file (OpenCV FileStorage); flags override its values |\n"
      "| `rate_hz` | Hz | 30 | rate |\n"
      "| `objects:` (section) |  |  | shape: sphere\\|box |\n"
      "| `chessboard:` (section) |  |  | board |\n");
}

TEST(Params, ErrorsNameTheFileFieldOrFlag) {
  ptz::Params p = makeParams();
  std::string err = parseError(p, {"prog", "--rate-hz", "fast"});
  EXPECT_NE(err.find("rate_hz"), std::string::npos) << err;
  err = parseError(p, {"prog", "--no-such-flag", "1"});
  EXPECT_NE(err.find("no-such-flag"), std::string::npos) << err;
  const std::string typo = writeTemp("typo.yaml", "%YAML:1.0\n---\nrate_hx: 60.0\n");
  err = parseError(p, {"prog", "--config", typo});
  EXPECT_NE(err.find(typo), std::string::npos) << err;
  EXPECT_NE(err.find("rate_hx"), std::string::npos) << err;
  err = parseError(p, {"prog", "--config", "/nonexistent/x.yaml"});
  EXPECT_NE(err.find("/nonexistent/x.yaml"), std::string::npos) << err;
  const std::string bad = writeTemp("bad.yaml", "%YAML:1.0\n---\nframes: 2.5\n");
  err = parseError(p, {"prog", "--config", bad});
  EXPECT_NE(err.find("frames"), std::string::npos) << err;
}

TEST(SceneConfig, ObjectsAreReadAndBadOnesNamed) {
  const std::string cfg = writeTemp(
      "scene.yaml",
      "%YAML:1.0\n---\nobjects:\n"
      "  - { name: \"a\", class: \"red_ball\", shape: \"sphere\", radius_m: 0.1,\n"
      "      color_bgr: [0, 0, 200], trajectory: \"circle\", centre_m: [0, 0, 3],\n"
      "      amplitude_m: [1, 0, 1], period_s: 10 }\n"
      "  - { name: \"b\", class: \"green_box\", shape: \"box\", half_extents_m: [0.1, 0.2, 0.3],\n"
      "      color_bgr: [0, 200, 0] }\n");
  ptz::Params p = makeParams();
  ASSERT_EQ(parseError(p, {"prog", "--config", cfg}), "");
  const auto scene = ptz::sim::Scene::fromConfig(p.section("scene"), p.section("objects"),
                                                 p.section("chessboard"), cfg);
  ASSERT_EQ(scene.objects.size(), 2u);
  EXPECT_EQ(scene.objects[1].class_name, "green_box");
  // A circle of radius 1 m in x/z about (0, 0, 3): a quarter period later it is at +z.
  EXPECT_NEAR(scene.objects[0].trajectory.position(0).x(), 1.0, 1e-12);
  EXPECT_NEAR(scene.objects[0].trajectory.position(2.5).z(), 4.0, 1e-12);

  const std::string bad = writeTemp("bad_scene.yaml",
                                    "%YAML:1.0\n---\nobjects:\n"
                                    "  - { name: \"a\", class: \"red_ball\", shape: \"cone\", "
                                    "radius_m: 0.1, color_bgr: [0, 0, 1] }\n");
  ptz::Params q = makeParams();
  ASSERT_EQ(parseError(q, {"prog", "--config", bad}), "");
  try {
    ptz::sim::Scene::fromConfig(q.section("scene"), q.section("objects"), q.section("chessboard"),
                                bad);
    FAIL() << "a cone is no shape of ours";
  } catch (const ptz::ConfigError& e) {
    const std::string err = e.what();
    EXPECT_NE(err.find("objects[0]"), std::string::npos) << err;
    EXPECT_NE(err.find("shape"), std::string::npos) << err;
  }
}
