// Params: config file values, flag overrides and errors that name the file, field or flag.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "common/config.hpp"

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
  t.add("rate_hz", 30.0, "Hz", "rate", ptz::Range::above(0));
  t.addSection("objects", "shape: sphere|box");
  t.addSection("chessboard", "board");
  EXPECT_EQ(
      t.markdownTable(),
      "| parameter | unit | default | range | meaning |\n|---|---|---|---|---|\n"
      "| `config` |  |  |  | YAML config file (OpenCV FileStorage); flags override its values |\n"
      "| `rate_hz` | Hz | 30 | > 0 | rate |\n"
      "| `objects:` (section) |  |  |  | shape: sphere\\|box |\n"
      "| `chessboard:` (section) |  |  |  | board |\n");
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

TEST(Params, RangesAreCheckedAndErrorsNameTheSourceTheParameterAndTheValue) {
  auto make = [] {
    ptz::Params p("prog", "test");
    p.add("rate_hz", 30.0, "Hz", "rate", ptz::Range::above(0));
    p.add("quality", 90, "", "quality", ptz::Range::between(1, 100));
    p.add("min_m", 0.3, "m", "nearest", ptz::Range::atLeast(0));
    p.add("max_m", 50.0, "m", "farthest", ptz::Range::atLeast(0));
    p.add("name", "a", "name");
    p.addOrder("min_m", "max_m");
    return p;
  };
  ptz::Params p = make();
  EXPECT_EQ(parseError(p, {"prog", "--rate-hz", "0"}),
            "flag --rate-hz: parameter 'rate_hz' must be > 0, got '0'");
  p = make();
  EXPECT_EQ(parseError(p, {"prog", "--quality=101"}),
            "flag --quality: parameter 'quality' must be within 1 .. 100, got '101'");
  const std::string cfg = writeTemp("range.yaml", "%YAML:1.0\n---\nrate_hz: -2.5\n");
  p = make();
  EXPECT_EQ(parseError(p, {"prog", "--config", cfg}),
            "config file '" + cfg + "': parameter 'rate_hz' must be > 0, got '-2.5'");
  // Orders: after all sources, each side named with its value and source.
  const std::string far = writeTemp("order.yaml", "%YAML:1.0\n---\nmax_m: 5.0\n");
  p = make();
  EXPECT_EQ(parseError(p, {"prog", "--config", far, "--min-m", "6"}),
            "parameter 'min_m' = 6 (flag --min-m) must be below parameter 'max_m' = 5 (config "
            "file '" +
                far + "')");
  p = make();
  EXPECT_EQ(parseError(p, {"prog", "--config", far, "--min-m", "6", "--max-m", "7"}), "");
  EXPECT_EQ(p.sourceOf("max_m"), "flag --max-m");
  EXPECT_EQ(p.sourceOf("rate_hz"), "default");
  EXPECT_EQ(std::string(p.invalid("name", "must be one of b, c").what()),
            "default: parameter 'name' must be one of b, c, got 'a'");
  // --help shows the range; a default outside its range is a programming error.
  EXPECT_NE(p.usage().find("(default 30; > 0)"), std::string::npos) << p.usage();
  EXPECT_NE(p.usage().find("(default 50; >= 0; > min_m)"), std::string::npos) << p.usage();
  EXPECT_NE(p.markdownTable().find("| `min_m` | m | 0.3 | >= 0; < max_m | nearest |"),
            std::string::npos)
      << p.markdownTable();
  ptz::Params q("prog", "test");
  EXPECT_THROW(q.add("x", 0.0, "", "x", ptz::Range::above(0)), std::logic_error);
  EXPECT_EQ(ptz::Range::above(0).andAtMost(1).text(), "> 0 and <= 1");
  EXPECT_EQ(ptz::Range::atMost(3).text(), "<= 3");
  EXPECT_EQ(ptz::Range().text(), "");
}

TEST(StructuredFiles, UnknownFieldsAndValuesOutOfRangeAreNamedWithTheirPath) {
  const std::string path =
      writeTemp("nested.yaml",
                "%YAML:1.0\n---\nobjects:\n  - { name: \"a\", speed_mps: 2, radius_m: -1, "
                "count: 2.5, color: [1, 300, 2] }\n");
  cv::FileStorage fs = ptz::openForRead(path, "config file");
  const cv::FileNode o = fs["objects"][0];
  const std::string where = "config file '" + path + "', objects[0]";
  auto error = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error([&] {
              ptz::checkFields(o, {"name", "radius_m", "count", "color"}, where);
            }),
            where + ".speed_mps: unknown field (known: name, radius_m, count, color)");
  EXPECT_EQ(error([&] { ptz::checkFields(fs["objects"], {"name"}, "config file 'x', objects"); }),
            "config file 'x', objects: must be a map of fields, got a list");
  EXPECT_EQ(error([&] { ptz::readDouble(o, "radius_m", where, ptz::Range::above(0)); }),
            where + ".radius_m: must be > 0, got '-1'");
  EXPECT_EQ(error([&] { ptz::readInt(o, "count", where); }),
            where + ".count: must be an integer, got '2.5'");
  EXPECT_EQ(error([&] { ptz::readDouble(o, "name", where); }),
            where + ".name: must be a number, got 'a'");
  EXPECT_EQ(error([&] { ptz::readNumbers(o, "color", 3, where, ptz::Range::between(0, 255)); }),
            where + ".color[1]: must be within 0 .. 255, got '300'");
  EXPECT_EQ(ptz::fieldPath("rig file 'r.yaml'", "image_width"), "rig file 'r.yaml', image_width");
}

// OpenCV keeps both of a repeated key and a lookup finds the first: a value added below an old one
// would be silently ignored, so every file read through openForRead refuses it, by its path.
TEST(StructuredFiles, AKeyGivenTwiceInOneMapIsRefusedWithItsPath) {
  ptz::Params p = makeParams();
  const std::string top = writeTemp("twice.yaml", "%YAML:1.0\n---\nrate_hz: 30\nrate_hz: 60\n");
  EXPECT_EQ(parseError(p, {"prog", "--config", top}),
            "config file '" + top + "': malformed (rate_hz: given twice; a map's keys are unique)");
  const std::string nested =
      writeTemp("twice_nested.yaml",
                "%YAML:1.0\n---\nobjects:\n  - { name: a }\n  - { name: b, radius_m: 1, "
                "radius_m: 2 }\n");
  auto openError = [](const std::string& path) {
    try {
      ptz::openForRead(path, "scene file");
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(openError(nested), "scene file '" + nested +
                                   "': malformed (objects[1].radius_m: given twice; a map's keys "
                                   "are unique)");
  // The same key in two maps, or twice in a list, is no repetition.
  const std::string fine =
      writeTemp("twice_fine.yaml",
                "%YAML:1.0\n---\nleft: { zoom: 1 }\nright:\n  zoom: 1\nlist: [1, 1]\nobjects:\n"
                "  - { name: a }\n  - { name: a }\n");
  EXPECT_EQ(openError(fine), "");
}

// A file named in a config file is found from the config file's folder, wherever the program
// runs; from a flag, from the current directory; absolute paths stay. A missing one is named
// with the config file, the parameter, its value and the resolved path.
TEST(Params, RelativePathsInAConfigFileAreFromItsFolder) {
  const std::string dir =
      (std::filesystem::path(::testing::TempDir()) / "relpaths").lexically_normal().string();
  std::filesystem::create_directories(dir + "/models");
  std::ofstream(dir + "/models/m.yaml") << "%YAML:1.0\n---\n";
  const std::string cfg = dir + "/driver.yaml";
  std::ofstream(cfg) << "%YAML:1.0\n---\nmodel: \"models/m.yaml\"\nabs: \"/etc/hostname\"\n"
                        "missing: \"models/none.yaml\"\nempty: \"\"\n";
  auto make = [] {
    ptz::Params p("prog", "test");
    for (const char* name : {"model", "abs", "missing", "empty"}) p.add(name, "", "a file");
    return p;
  };
  ptz::Params p = make();
  EXPECT_EQ(parseError(p, {"prog", "--config", cfg}), "");
  EXPECT_EQ(p.getString("model"), "models/m.yaml");
  EXPECT_EQ(p.getPath("model"), dir + "/models/m.yaml");
  EXPECT_EQ(p.getExistingPath("model"), dir + "/models/m.yaml");
  EXPECT_EQ(p.getPath("abs"), "/etc/hostname");
  EXPECT_EQ(p.getExistingPath("empty"), "");
  std::string err;
  try {
    p.getExistingPath("missing");
  } catch (const ptz::ConfigError& e) {
    err = e.what();
  }
  EXPECT_EQ(err, "config file '" + cfg + "': parameter 'missing' = 'models/none.yaml': '" + dir +
                     "/models/none.yaml' does not exist (relative paths in a config file are "
                     "from its folder)");

  // A flag overrides the file's value and is taken from the current directory.
  ptz::Params q = make();
  EXPECT_EQ(parseError(q, {"prog", "--config", cfg, "--model", "here/m.yaml"}), "");
  EXPECT_EQ(q.getPath("model"), "here/m.yaml");
  EXPECT_EQ(q.getPath("missing"), dir + "/models/none.yaml");
}
