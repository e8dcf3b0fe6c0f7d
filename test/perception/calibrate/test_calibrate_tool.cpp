// ptz-calibrate on bad input: each case a clear message naming the files and a non-zero exit; and
// rig files that are missing or truncated refused by StereoRig::load.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "common/rig.hpp"
#include "support/board_views.hpp"
#include "support/data_dir.hpp"

namespace {

namespace fs = std::filesystem;

struct ToolRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

ToolRun runCalibrate(const std::string& args) {
  ToolRun run;
  FILE* pipe = popen((std::string(PTZ_CALIBRATE_BIN) + " " + args + " 2>&1").c_str(), "r");
  if (!pipe) return run;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

std::string sampleDir() {
  return ptz::test::dataDir() + "/opencv_stereo_calib";
}

// A fresh folder under the test temp dir.
std::string freshDir(const std::string& name) {
  const std::string dir = std::string(::testing::TempDir()) + "/ptz_calibrate_" + name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A list file of the first `count` sample pairs.
std::string sampleList(const std::string& dir, int count) {
  const std::string path = dir + "/pairs.txt";
  std::ofstream out(path);
  for (int i = 1; i <= count; ++i) {
    out << sampleDir() << "/left0" << i << ".jpg " << sampleDir() << "/right0" << i << ".jpg\n";
  }
  return path;
}

void expectContains(const ToolRun& run, const std::string& text) {
  EXPECT_NE(run.output.find(text), std::string::npos) << "expected '" << text << "' in:\n"
                                                      << run.output;
}

#define SKIP_WITHOUT_SAMPLE() PTZ_REQUIRE_DATA(sampleDir())

TEST(CalibrateTool, WrongBoardSizeSaysNoCornersAndSuggestsCheckingIt) {
  SKIP_WITHOUT_SAMPLE();
  const std::string dir = freshDir("wrong_board");
  const ToolRun run = runCalibrate("--image-list " + sampleList(dir, 3) +
                                   " --board-cols 7 --board-rows 5 --output " + dir + "/rig.yaml");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  expectContains(run, "no chessboard of 7x5 inner corners found in any of the 6 images");
  expectContains(run, "left01.jpg");
  expectContains(run, "check the board size");
  EXPECT_FALSE(fs::exists(dir + "/rig.yaml"));
}

TEST(CalibrateTool, ImagesOfDifferentSizesAreNamed) {
  SKIP_WITHOUT_SAMPLE();
  const std::string dir = freshDir("sizes");
  cv::Mat right = cv::imread(sampleDir() + "/right01.jpg"), small;
  cv::resize(right, small, {320, 240});
  cv::imwrite(dir + "/left01.png", cv::imread(sampleDir() + "/left01.jpg"));
  cv::imwrite(dir + "/right01.png", small);
  const ToolRun run = runCalibrate("--images-dir " + dir + " --output " + dir + "/rig.yaml");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  expectContains(run, "images of different sizes");
  expectContains(run, dir + "/right01.png is 320x240");
}

TEST(CalibrateTool, LeftRightCountMismatchNamesTheFilesWithoutPartner) {
  SKIP_WITHOUT_SAMPLE();
  const std::string dir = freshDir("count");
  for (const char* name : {"left01.jpg", "left02.jpg", "right01.jpg"}) {
    fs::copy_file(sampleDir() + "/" + name, dir + "/" + name);
  }
  const ToolRun run = runCalibrate("--images-dir " + dir + " --output " + dir + "/rig.yaml");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  expectContains(run, "left/right count mismatch (2 left*, 1 right*)");
  expectContains(run, dir + "/left02.jpg (no right02.jpg)");
}

TEST(CalibrateTool, UnreadableFilesAreNamed) {
  SKIP_WITHOUT_SAMPLE();
  const std::string dir = freshDir("unreadable");
  fs::copy_file(sampleDir() + "/left01.jpg", dir + "/left01.jpg");
  std::ofstream(dir + "/right01.jpg") << "not an image";
  ToolRun run = runCalibrate("--images-dir " + dir + " --output " + dir + "/rig.yaml");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  expectContains(run, "cannot read these images");
  expectContains(run, dir + "/right01.jpg");
  run = runCalibrate("--images-dir " + dir + "/missing --output " + dir + "/rig.yaml");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  expectContains(run, dir + "/missing': not a readable folder");
}

TEST(CalibrateTool, TooFewViewsSaysHowManyAndWhich) {
  SKIP_WITHOUT_SAMPLE();
  const std::string dir = freshDir("few");
  const ToolRun run =
      runCalibrate("--image-list " + sampleList(dir, 3) + " --output " + dir + "/rig.yaml");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  expectContains(run, "too few views: 3");
  expectContains(run, "need at least 8");
  expectContains(run, "right03.jpg");
}

TEST(CalibrateTool, FrontoParallelViewsAreRefusedAsDegenerate) {
  // Ten fronto-parallel views at different places and distances, rendered by the simulator.
  const std::string dir = freshDir("degenerate");
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ptz::test::BoardScene sim;
  for (int i = 0; i < 10; ++i) {
    sim.chessboard().centre_head_m = {0.1 * (i % 3 - 1), 0.08 * (i % 2), 1.2 + 0.06 * i};
    for (ptz::Side side : {ptz::Side::kLeft, ptz::Side::kRight}) {
      cv::imwrite(dir + "/" + ptz::sideName(side) + std::to_string(10 + i) + ".png",
                  sim.render(rig.view(side, {})));
    }
  }
  const ToolRun run =
      runCalibrate("--images-dir " + dir + " --square-m 0.05 --output " + dir + "/rig.yaml");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  expectContains(run, "degenerate views");
  expectContains(run, dir + "/left10.png");
}

TEST(CalibrateTool, ACameraInfoFolderThatCannotBeMadeIsRefusedBeforeTheWork) {
  SKIP_WITHOUT_SAMPLE();
  const std::string dir = freshDir("info_unwritable");
  std::ofstream(dir + "/a_file") << "not a folder\n";
  const ToolRun run = runCalibrate("--images-dir " + sampleDir() + " --output " + dir +
                                   "/rig.yaml --camera-info-dir " + dir + "/a_file/info");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_EQ(
      run.output.rfind(
          "ptz-calibrate: camera_info_dir '" + dir + "/a_file/info': cannot " + "create it: ", 0),
      0u)
      << run.output;
  EXPECT_EQ(run.output.find("image 1/"), std::string::npos) << "it started the work first";
  EXPECT_FALSE(fs::exists(dir + "/rig.yaml"));
}

TEST(CalibrateTool, WritesARigFileEveryProcessLoadsAndRefusesItTruncated) {
  SKIP_WITHOUT_SAMPLE();
  const std::string dir = freshDir("output");
  const std::string info = dir + "/camera_info/home";  // made by ptz-calibrate
  const ToolRun run = runCalibrate("--images-dir " + sampleDir() + " --output " + dir +
                                   "/rig.yaml --camera-info-dir " + info);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // Progress on stderr: the last image's line and every stage, in order.
  size_t at = 0;
  for (const std::string& line : std::vector<std::string>{
           "ptz-calibrate: image 26/26 (", "ptz-calibrate: mono calibration, left camera: 13 views",
           "ptz-calibrate: mono calibration, right camera", "ptz-calibrate: stereo calibration (",
           "ptz-calibrate: rectification...", "wrote " + info + "/right.yaml"}) {
    const size_t next = run.output.find(line, at);
    ASSERT_NE(next, std::string::npos) << "'" << line << "' (in order) not in:\n" << run.output;
    at = next;
  }
  const ptz::StereoRig rig = ptz::StereoRig::load(dir + "/rig.yaml");
  EXPECT_EQ(rig.left.width, 640);
  EXPECT_NEAR(rig.baselineM() / 0.025, 3.345, 3.345 * 0.005);
  cv::FileStorage fs(dir + "/rig.yaml", cv::FileStorage::READ);
  for (const char* field : {"E", "F", "R1", "R2", "P1", "P2", "Q"}) {
    EXPECT_FALSE(fs[field].empty()) << field;
  }
  const cv::FileNode report = fs["calibration"];
  EXPECT_EQ(report["views"].size(), 13u);
  EXPECT_LE(static_cast<double>(report["rms_stereo_px"]), 0.45);
  EXPECT_FALSE(static_cast<std::string>(report["date_utc"]).empty());
  EXPECT_TRUE(fs::exists(info + "/left.yaml") && fs::exists(info + "/right.yaml"));

  // Cut anywhere: load() refuses the file and names it.
  std::ifstream in(dir + "/rig.yaml");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string truncated = dir + "/truncated.yaml";
  for (double fraction : {0.1, 0.3, 0.5, 0.7, 0.9, 0.99}) {
    std::ofstream(truncated) << text.substr(0, static_cast<size_t>(fraction * text.size()));
    try {
      ptz::StereoRig::load(truncated);
      ADD_FAILURE() << "a rig file cut at " << fraction << " of its size was accepted";
    } catch (const ptz::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(truncated), std::string::npos) << e.what();
    }
  }
}

}  // namespace
