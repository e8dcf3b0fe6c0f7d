// Params: config file values, flag overrides and errors that name the file, field or flag.
#include <gtest/gtest.h>

#include <fstream>

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
