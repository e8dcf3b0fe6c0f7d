// Ground truth in every format ptz-depth-eval reads, written here with known disparities: 8-bit
// PNG (Middlebury 2001-2006), 16-bit PNG (KITTI: value / 256, 0 invalid), PFM (Middlebury 2014:
// float px, inf invalid, rows bottom to top, little- or big-endian); the same synthetic pair
// scored against each, and bad files refused before anything is decoded.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "perception/depth_eval/stereo_eval.hpp"
#include "support/error_of.hpp"
#include "support/run_program.hpp"

namespace perception = ptz::perception;

namespace {

constexpr int kWidth = 320, kHeight = 240;
constexpr float kInf = std::numeric_limits<float>::infinity();

std::string tempPath(const std::string& name) {
  return std::string(::testing::TempDir()) + "gt_" + name;
}

// The true disparity: 6.5 px in the top half, 12.25 px in the bottom half; unknown in the 30
// leftmost columns (PFM: inf; PNG: 0).
float trueDisparity(int x, int y) {
  if (x < 30) return kInf;
  return y < kHeight / 2 ? 6.5f : 12.25f;
}

// PFM as Middlebury 2014 writes it: "Pf", width height, scale (negative: little-endian), the
// rows from the bottom up.
void writePfm(const std::string& path, bool little_endian) {
  std::ofstream f(path, std::ios::binary);
  f << "Pf\n" << kWidth << " " << kHeight << "\n" << (little_endian ? "-1.0" : "1.0") << "\n";
  for (int y = kHeight - 1; y >= 0; --y) {
    for (int x = 0; x < kWidth; ++x) {
      const float v = trueDisparity(x, y);
      unsigned char b[4];
      std::memcpy(b, &v, 4);  // this machine: little-endian
      if (!little_endian) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
      f.write(reinterpret_cast<const char*>(b), 4);
    }
  }
}

void writePng(const std::string& path, int depth, double scale) {
  cv::Mat m(kHeight, kWidth, depth == 16 ? CV_16U : CV_8U);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const float d = trueDisparity(x, y);
      const double v = std::isfinite(d) ? std::round(d * scale) : 0;
      if (depth == 16) {
        m.at<uint16_t>(y, x) = static_cast<uint16_t>(v);
      } else {
        m.at<uint8_t>(y, x) = static_cast<uint8_t>(v);
      }
    }
  }
  ASSERT_TRUE(cv::imwrite(path, m));
}

// A textured left image and the right one it gives at trueDisparity (x_right = x_left - d,
// bilinear for the fractional part); what the unknown columns hold does not matter.
void writePair(const std::string& left, const std::string& right) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> grey(0, 255);
  cv::Mat coarse(kHeight / 2 + 1, kWidth / 2 + 20, CV_8U);
  for (auto it = coarse.begin<uint8_t>(); it != coarse.end<uint8_t>(); ++it) {
    *it = static_cast<uint8_t>(grey(rng));
  }
  cv::Mat l;
  cv::resize(coarse, l, {kWidth + 40, kHeight + 2}, 0, 0, cv::INTER_LINEAR);
  cv::Mat r(kHeight, kWidth, CV_8U);
  for (int y = 0; y < kHeight; ++y) {
    const float d = y < kHeight / 2 ? 6.5f : 12.25f;
    for (int x = 0; x < kWidth; ++x) {
      const float xs = x + d;  // the left pixel seen at right x
      const int x0 = static_cast<int>(std::floor(xs));
      const float a = xs - x0;
      r.at<uint8_t>(y, x) =
          cv::saturate_cast<uint8_t>((1 - a) * l.at<uint8_t>(y, x0) + a * l.at<uint8_t>(y, x0 + 1));
    }
  }
  ASSERT_TRUE(cv::imwrite(left, l(cv::Rect(0, 0, kWidth, kHeight))));
  ASSERT_TRUE(cv::imwrite(right, r));
}

double jsonNumber(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return NAN;
  return std::strtod(json.c_str() + at + key.size() + 4, nullptr);
}

}  // namespace

TEST(GroundTruth, EachFormatGivesTheDisparityInPixels) {
  const std::string le = tempPath("le.pfm"), be = tempPath("be.pfm"), p16 = tempPath("16.png"),
                    p8 = tempPath("8.png");
  writePfm(le, true);
  writePfm(be, false);
  writePng(p16, 16, 256);
  writePng(p8, 8, 4);
  struct Case {
    std::string path;
    double scale;
    std::string format;
  };
  for (const Case& c :
       {Case{le, 0, "float PFM, scale 1"}, Case{be, 0, "float PFM, scale 1"},
        Case{p16, 0, "16-bit PNG, scale 256"}, Case{p16, 256, "16-bit PNG, scale 256"},
        Case{p8, 4, "8-bit PNG, scale 4"}}) {
    std::string format;
    const cv::Mat gt = perception::loadGroundTruth(c.path, c.scale, {kWidth, kHeight}, &format);
    EXPECT_EQ(format, c.format) << c.path;
    ASSERT_EQ(gt.type(), CV_32F);
    EXPECT_EQ(gt.at<float>(0, 100), 6.5f) << c.path;  // the top row is the top (PFM: last)
    EXPECT_EQ(gt.at<float>(kHeight - 1, 100), 12.25f) << c.path;
    EXPECT_EQ(gt.at<float>(50, 10), 0.0f) << c.path;  // inf / 0: unknown
  }
}

TEST(GroundTruth, BadFilesAreRefusedBeforeTheyAreDecoded) {
  const cv::Size size(kWidth, kHeight);
  auto error = [&](const std::string& path) {
    return ptz::test::errorOf([&] { perception::loadGroundTruth(path, 0, size); });
  };
  // A header asking for 100000 x 100000 floats in a file of a few bytes.
  const std::string huge = tempPath("huge.pfm");
  std::ofstream(huge, std::ios::binary) << "Pf\n100000 100000\n-1.0\n" << std::string(16, 'x');
  EXPECT_EQ(error(huge), "ground truth '" + huge +
                             "': the PFM header says 100000x100000 (40000000000 bytes of data), "
                             "the file has 16: truncated or not PFM");
  const std::string cut = tempPath("cut.pfm");
  writePfm(cut, true);
  std::filesystem::resize_file(cut, std::filesystem::file_size(cut) - 4);
  EXPECT_NE(error(cut).find("the file has 307196: truncated or not PFM"), std::string::npos)
      << error(cut);
  const std::string colour = tempPath("colour.pfm");
  std::ofstream(colour, std::ios::binary) << "PF\n2 1\n-1.0\n" << std::string(24, '\0');
  EXPECT_EQ(error(colour),
            "ground truth '" + colour + "': has 3 channels; a disparity map has one");
  const std::string junk = tempPath("junk.pfm");
  std::ofstream(junk, std::ios::binary) << "Pf\n-3 2\nbig\n";
  EXPECT_NE(error(junk).find("a PFM header must be"), std::string::npos) << error(junk);
  const std::string small = tempPath("small.png");
  cv::imwrite(small, cv::Mat(10, 20, CV_16U, cv::Scalar(1)));
  EXPECT_EQ(error(small), "ground truth '" + small + "': is 20x10, the left image 320x240");
  const std::string rgb = tempPath("rgb16.png");
  cv::imwrite(rgb, cv::Mat(kHeight, kWidth, CV_16UC3, cv::Scalar(1, 2, 3)));
  EXPECT_EQ(error(rgb), "ground truth '" + rgb + "': has 3 channels; a disparity map has one");
}

// The same pair scored by ptz-depth-eval against each file: all equally good. Read as 8-bit (as
// before), the KITTI file's disparities were a 256th of the truth and nearly every pixel bad.
TEST(GroundTruth, DepthEvalScoresThePairAlikeWithEveryFormat) {
  const std::string left = tempPath("left.png"), right = tempPath("right.png");
  writePair(left, right);
  const std::string le = tempPath("eval_le.pfm"), be = tempPath("eval_be.pfm"),
                    p16 = tempPath("eval_16.png"), p8 = tempPath("eval_8.png");
  writePfm(le, true);
  writePfm(be, false);
  writePng(p16, 16, 256);
  writePng(p8, 8, 4);
  const int64_t known = int64_t{kWidth - 30 - 10} * (kHeight - 20);  // unknown columns, border
  for (const auto& [gt, scale] : std::vector<std::pair<std::string, std::string>>{
           {le, "0"}, {be, "0"}, {p16, "256"}, {p16, "0"}, {p8, "4"}}) {
    const auto r = ptz::test::runProgram({PTZ_DEPTH_EVAL_BIN, "--left", left, "--right", right,
                                          "--gt", gt, "--scale", scale, "--mode", "sgbm",
                                          "--full-width", "true", "--num-disparities", "16"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(jsonNumber(r.out, "known_px"), known) << gt << ": " << r.out;
    EXPECT_LT(jsonNumber(r.out, "bad_all"), 0.03) << gt << ": " << r.out;
  }
  // Each problem named with the file: a truncated PFM, a size that is not the pair's.
  const std::string small = tempPath("eval_small.png");
  cv::imwrite(small, cv::Mat(10, 20, CV_16U, cv::Scalar(1)));
  const auto r =
      ptz::test::runProgram({PTZ_DEPTH_EVAL_BIN, "--left", left, "--right", right, "--gt", small});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "ptz-depth-eval: ground truth '" + small + "': is 20x10, the left image 320x240\n");
  const auto order = ptz::test::runProgram(
      {PTZ_DEPTH_EVAL_BIN, "--left", left, "--right", right, "--gt", p8, "--min-depth-m", "30"});
  EXPECT_EQ(order.exit_code, 2);
  EXPECT_EQ(order.err,
            "ptz-depth-eval: parameter 'min_depth_m' = 30 (flag --min-depth-m) must be below "
            "parameter 'max_depth_m' = 20 (default)\n");
}
