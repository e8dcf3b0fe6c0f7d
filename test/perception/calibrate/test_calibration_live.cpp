// The live source's view selection, fed with simulator frames as ptz-calibrate --source lcm feeds
// it with decoded STEREO_FRAMEs; the frames it takes (at home) and what it does with a kept view.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <random>

#include "perception/calibrate/calibrate_tool.hpp"
#include "perception/calibrate/calibration_live.hpp"
#include "support/board_views.hpp"

namespace {

using ptz::perception::BoardSpec;
using ptz::perception::LiveCollector;

TEST(CalibrationCoverage, MeasuresPositionSizeAndSkewLikeRos) {
  const BoardSpec board{9, 6, 0.025};
  const cv::Size image(640, 480);
  // A fronto-parallel board of 30 px squares centred in the image: 240 x 150 px.
  std::vector<cv::Point2f> centred;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 9; ++c) centred.emplace_back(200.f + 30.f * c, 165.f + 30.f * r);
  }
  const auto v = ptz::perception::coverageOf(centred, board, image);
  const double border = std::sqrt(240.0 * 150.0);
  EXPECT_NEAR(v.x, (320 - border / 2) / (640 - border), 1e-6);
  EXPECT_NEAR(v.y, (240 - border / 2) / (480 - border), 1e-6);
  EXPECT_NEAR(v.size, std::sqrt(240.0 * 150.0 / (640 * 480)), 1e-6);
  EXPECT_NEAR(v.skew, 0, 1e-6);
  // Shear the rows sideways by 10 deg: skew = 2 * 10 deg in radians.
  std::vector<cv::Point2f> sheared = centred;
  for (auto& p : sheared) p.x += static_cast<float>((p.y - 165) * std::tan(10 * M_PI / 180));
  EXPECT_NEAR(ptz::perception::coverageOf(sheared, board, image).skew, 2 * 10 * M_PI / 180, 1e-3);
}

TEST(LiveCollector, KeepsOnlyViewsThatAddCoverageAndCalibratesFromThem) {
  std::mt19937 rng(7);
  const ptz::StereoRig truth = ptz::test::randomRig(rng);
  ptz::test::BoardScene sim;
  ptz::sim::Chessboard& chessboard = sim.chessboard();
  const BoardSpec board = sim.board;
  const std::vector<ptz::CameraView> views = {truth.view(ptz::Side::kLeft, {}),
                                              truth.view(ptz::Side::kRight, {})};
  LiveCollector collector(board);
  std::map<LiveCollector::Result, int> results;
  auto offer = [&](const std::string& name) {
    const auto r = collector.offer(sim.render(views[0]), sim.render(views[1]), name);
    ++results[r];
    return r;
  };
  // No board in view; then the board where only the left camera sees it.
  chessboard.centre_head_m = {0, 0, -2};
  EXPECT_EQ(offer("no board"), LiveCollector::Result::kNoBoard);
  chessboard.rotation_head_board.setIdentity();
  for (double x = -1; x < 0; x += 0.01) {  // the right camera sits at +x: move the board left
    chessboard.centre_head_m = {x, 0, 1.0};
    if (ptz::test::boardInside(chessboard, views[0], 5)) break;
  }
  ASSERT_TRUE(ptz::test::boardInside(chessboard, views[0], 5));
  ASSERT_FALSE(ptz::test::boardInside(chessboard, views[1], 0));
  EXPECT_EQ(offer("left only"), LiveCollector::Result::kNotBothImages);
  // A stream of random poses, each shown twice (a still board): the repeat adds nothing.
  for (int i = 0; collector.views().size() < 20 && i < 200; ++i) {
    ASSERT_TRUE(
        ptz::test::placeBoard(rng, views, {0, 0, 1.3}, {0.35, 0.25, 0.3}, 0.7, &chessboard));
    if (offer("frame " + std::to_string(i)) == LiveCollector::Result::kKept) {
      EXPECT_EQ(offer("frame " + std::to_string(i) + " again"),
                LiveCollector::Result::kNoNewCoverage);
    }
  }
  ASSERT_EQ(collector.views().size(), 20u);
  EXPECT_GT(results[LiveCollector::Result::kNoNewCoverage], 20);
  // Boards spread over +-0.35 m x +-0.25 m at 1-1.6 m, tilted up to 40 deg.
  const auto progress = collector.progress();
  EXPECT_GT(progress[0], 0.5) << collector.progressText();
  EXPECT_GT(progress[1], 0.5) << collector.progressText();
  EXPECT_GT(progress[2], 0.2) << collector.progressText();
  EXPECT_GT(progress[3], 0.5) << collector.progressText();
  const auto c =
      ptz::perception::calibrateStereo(collector.views(), board, collector.imageSize(), {});
  EXPECT_LT(std::abs(c.toRig().baselineM() - truth.baselineM()) / truth.baselineM(), 0.005);
}

// ptz-calibrate --source lcm's frame handling (LiveViews): frames off home are refused with the
// reason, a kept view is saved and printed, the target ends the run.
TEST(LiveViews, TakesFramesAtHomeAndSavesKeptViews) {
  char dir_template[] = "/tmp/ptz_calibrate_live_XXXXXX";
  const std::string dir = ::mkdtemp(dir_template);
  ptz::Params p("ptz-calibrate", "test");
  ptz::perception::declareCalibrateParams(p);
  const std::string save = "--save-views-dir=" + dir;
  std::vector<std::string> args = {"ptz-calibrate",
                                   "--board-cols=9",
                                   "--board-rows=6",
                                   "--square-m=0.05",
                                   "--target-views=1",
                                   "--zoom=2",
                                   save};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  ASSERT_TRUE(p.parse(static_cast<int>(argv.size()), argv.data()));
  ptz::perception::LiveViews live(p);

  ptzstereo::stereo_frame_t m{};
  m.left.zoom = m.right.zoom = 2.0;
  EXPECT_EQ(live.notAtHome(m), "");
  m.right.tilt_rad = 0.0019;  // within home_tolerance_rad 0.002
  EXPECT_EQ(live.notAtHome(m), "");
  m.left.pan_rad = 0.003;
  EXPECT_EQ(live.notAtHome(m),
            "cameras not at pan = tilt = 0 and zoom 2.000000 (home_tolerance_rad, --zoom)");
  m.left.pan_rad = 0;
  m.right.zoom = 1.0;
  EXPECT_NE(live.notAtHome(m), "");

  std::mt19937 rng(7);
  const ptz::StereoRig truth = ptz::test::randomRig(rng);
  ptz::test::BoardScene sim;
  const std::vector<ptz::CameraView> views = {truth.view(ptz::Side::kLeft, {}),
                                              truth.view(ptz::Side::kRight, {})};
  sim.chessboard().centre_head_m = {0, 0, -2};  // behind the cameras
  EXPECT_EQ(live.offer(sim.render(views[0]), sim.render(views[1]), 41),
            LiveCollector::Result::kNoBoard);
  EXPECT_FALSE(live.done());
  ASSERT_TRUE(
      ptz::test::placeBoard(rng, views, {0, 0, 1.3}, {0.2, 0.1, 0.2}, 0.5, &sim.chessboard()));
  EXPECT_EQ(live.offer(sim.render(views[0]), sim.render(views[1]), 42),
            LiveCollector::Result::kKept);
  EXPECT_TRUE(live.done());
  EXPECT_EQ(live.collector().views().at(0).left_name.rfind("frame 42", 0), 0u);
  EXPECT_TRUE(std::filesystem::exists(dir + "/left001.png"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/right001.png"));
  std::filesystem::remove_all(dir);
}

}  // namespace
