// The colour classes of a config file and ptz-detect's settings: what is wrong is refused with
// the file (or flag), the field and the value named.
#include <gtest/gtest.h>

#include <fstream>

#include "perception/detection/detector.hpp"
#include "support/error_of.hpp"
#include "support/run_program.hpp"

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = std::string(::testing::TempDir()) + "/" + name;
  std::ofstream(path) << "%YAML:1.0\n---\n" << text;
  return path;
}

std::string classesError(const std::string& yaml) {
  const std::string path = writeTemp("classes.yaml", yaml);
  cv::FileStorage fs = ptz::openForRead(path, "config file");
  return ptz::test::errorOf(
      [&] { ptz::perception::DetectorParams::fromConfig(fs["classes"], "config file 'c.yaml'"); });
}

const std::string kRed = "  - { name: \"red_ball\", hue_min_deg: 340, hue_max_deg: 20";

// ptz-detect on memq:// (no network): it stops at its settings, exit 2 and one line on stderr.
ptz::test::ProgramResult detect(std::vector<std::string> args) {
  args.insert(args.begin(), {PTZ_DETECT_BIN, "--lcm-url", "memq://"});
  return ptz::test::runProgram(args);
}

}  // namespace

TEST(DetectConfig, ClassesRefuseUnknownFieldsEmptyListsAndValuesOutOfRange) {
  const std::string unknown = "config file 'c.yaml', classes[0].saturation_mn: unknown field";
  EXPECT_EQ(
      classesError("classes:\n" + kRed + ", saturation_mn: 0.4 }\n").substr(0, unknown.size()),
      unknown);
  EXPECT_EQ(classesError("classes: []\n"),
            "config file 'c.yaml', classes: must be a non-empty list");
  EXPECT_EQ(classesError("classes:\n" + kRed + ", saturation_min: 1.5 }\n"),
            "config file 'c.yaml', classes[0].saturation_min: must be within 0 .. 1, got '1.5'");
  EXPECT_EQ(
      classesError("classes:\n" + kRed + ", min_area_px2: 500, max_area_px2: 100 }\n"),
      "config file 'c.yaml', classes[0].min_area_px2 = 500 must be at most max_area_px2 = 100");
  EXPECT_EQ(classesError("classes:\n" + kRed + " }\n" + kRed + " }\n"),
            "config file 'c.yaml', classes[1].name: a second class named 'red_ball'");
  EXPECT_EQ(classesError("classes:\n" + kRed + ", shape: \"cone\" }\n"),
            "config file 'c.yaml', classes[0].shape: must be circle, square or any, got 'cone'");
  EXPECT_EQ(classesError("classes:\n" + kRed + " }\n"), "");
}

TEST(DetectConfig, TheProgramRefusesSettingsThatContradictEachOther) {
  const std::string cfg = PTZ_SOURCE_DIR "/config/detect_default.yaml";
  auto r = detect({"--config", cfg, "--min-range-m", "60"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "ptz-detect: parameter 'min_range_m' = 60 (flag --min-range-m) must be below "
            "parameter 'max_range_m' = 50 (default)\n");
  r = detect({"--config", cfg, "--target-class", "purple_cube"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "ptz-detect: flag --target-class: parameter 'target_class' must be one of the classes "
            "of config file '" +
                cfg + "' (red_ball, green_box, blue_ball), got 'purple_cube'\n");
  r = detect({"--config", cfg, "--filter-size-px", "4"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "ptz-detect: flag --filter-size-px: parameter 'filter_size_px' must be odd, got '4'\n");
  const std::string empty = writeTemp("no_classes.yaml", "classes: []\n");
  r = detect({"--config", empty});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "ptz-detect: config file '" + empty + "', classes: must be a non-empty list\n");
}
