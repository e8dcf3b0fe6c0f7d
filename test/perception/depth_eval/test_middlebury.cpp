// ptz-depth-eval on Middlebury pairs with ground truth: ptz-depth's matchers no worse than
// OpenCV's references set by set, and the scoring's rules.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "perception/depth_eval/stereo_eval.hpp"
#include "support/data_dir.hpp"

namespace perception = ptz::perception;

namespace {

struct MiddleburySet {
  const char* folder;
  const char *left, *right, *gt, *gt_right;
  double scale;
  int num_disparities;
  double opencv_sgbm, opencv_bm;  // reference rows of ../shared/data/README.md
};

const MiddleburySet kSets[] = {
    {"2001/tsukuba", "im3.png", "im4.png", "disp3.pgm", "", 16, 16, 0.044, 0.123},
    {"2001/venus", "im2.png", "im6.png", "disp2.pgm", "", 8, 32, 0.147, 0.124},
    {"2003/teddy", "im2.png", "im6.png", "disp2.png", "", 4, 64, 0.149, 0.199},
    {"2003/cones", "im2.png", "im6.png", "disp2.png", "disp6.png", 4, 64, 0.141, 0.173},
};

// Runs ptz-depth-eval and returns its JSON line.
std::string runEval(const MiddleburySet& s, const std::string& dir, const std::string& flags) {
  std::ostringstream cmd;
  cmd << PTZ_DEPTH_EVAL_BIN << " --left " << dir << s.left << " --right " << dir << s.right
      << " --gt " << dir << s.gt << " --scale " << s.scale << " --num-disparities "
      << s.num_disparities << " " << flags;
  if (*s.gt_right) cmd << " --gt-right " << dir << s.gt_right;
  FILE* pipe = popen(cmd.str().c_str(), "r");
  std::string out;
  char buf[512];
  while (pipe && fgets(buf, sizeof buf, pipe)) out += buf;
  if (pipe) {
    EXPECT_EQ(pclose(pipe), 0) << cmd.str();
  }
  return out;
}

double jsonNumber(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return NAN;
  return std::stod(json.substr(at + key.size() + 4));
}

}  // namespace

// BM: the paper's matcher (normalised 7x7 pre-filter, SAD window) over the full width; the
// filters that only remove pixels are off, as the score counts a removed pixel as bad.
// SGBM: the quality mode with its defaults, over the full width.
TEST(Middlebury, BmAndSgbmNoWorseThanOpenCvsReferenceOnEverySet) {
  const std::string root = ptz::test::dataDir() + "/middlebury/";
  PTZ_REQUIRE_DATA(root);
  for (const auto& s : kSets) {
    const std::string dir = root + s.folder + "/";
    const std::string bm = runEval(s, dir,
                                   "--mode bm --full-width true --uniqueness-pct 0 "
                                   "--speckle-window-px 0 --lr-max-diff-px -1");
    const std::string sgbm = runEval(s, dir, "--mode sgbm --full-width true");
    const std::string wls = runEval(s, dir, "--mode sgbm --full-width true --wls true");
    std::printf("%s bm: %s%s sgbm: %s%s sgbm+wls: %s", s.folder, bm.c_str(), s.folder, sgbm.c_str(),
                s.folder, wls.c_str());
    EXPECT_LE(jsonNumber(bm, "bad_nonocc"), s.opencv_bm) << s.folder;
    EXPECT_LE(jsonNumber(sgbm, "bad_nonocc"), s.opencv_sgbm) << s.folder;
    // WLS fills (nearly) every pixel; it trades some accuracy at edges for that (still better than
    // BM's reference).
    EXPECT_LT(jsonNumber(wls, "invalid_fraction"), 0.001) << s.folder;
    EXPECT_LE(jsonNumber(wls, "bad_nonocc"), s.opencv_bm) << s.folder;
    EXPECT_GE(jsonNumber(bm, "bad_all"), jsonNumber(bm, "bad_nonocc")) << s.folder;
  }
}

TEST(Middlebury, ScoringCountsInvalidAsBadSkipsUnknownAndTheBorder) {
  cv::Mat gt(40, 40, CV_32F, cv::Scalar(5.0f));
  gt(cv::Rect(0, 0, 40, 20)).setTo(0);  // top half unknown
  cv::Mat disp = gt.clone();
  disp.at<float>(25, 15) = NAN;  // invalid: bad
  disp.at<float>(26, 15) = 6.5;  // 1.5 px off: bad
  disp.at<float>(27, 15) = 5.9;  // 0.9 px off: good
  disp.at<float>(35, 35) = 0;    // in the border: ignored
  const cv::Mat all(gt.size(), CV_8U, cv::Scalar(255));
  const perception::StereoScore s = perception::scoreDisparity(disp, gt, all, 10, 1.0);
  EXPECT_EQ(s.known_px, 20 * 10);  // rows 20..29, columns 10..29
  EXPECT_DOUBLE_EQ(s.bad_all, 2.0 / 200);
  EXPECT_DOUBLE_EQ(s.invalid_fraction, 1.0 / 200);
  // A near surface (d = 9) at columns 20..29 hides the far one (d = 5) that would land there.
  cv::Mat step(1, 40, CV_32F, cv::Scalar(5.0f));
  step.colRange(20, 30).setTo(9.0f);
  const cv::Mat mask = perception::nonOccludedMask(step, cv::Mat());
  EXPECT_EQ(mask.at<uint8_t>(0, 2), 0);     // x - d < 0: outside the right image
  EXPECT_EQ(mask.at<uint8_t>(0, 10), 255);  // lands on 5, nothing nearer there
  EXPECT_EQ(mask.at<uint8_t>(0, 17), 0);    // lands on 12, where d = 9 pixels land too
  EXPECT_EQ(mask.at<uint8_t>(0, 25), 255);
}
