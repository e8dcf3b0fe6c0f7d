// ptz-depth-eval: scores ptz-depth's matcher on a stereo pair with ground truth (Middlebury) and
// prints the bad-pixel fractions as JSON.
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <iostream>

#include "common/config.hpp"
#include "perception/depth/depth.hpp"
#include "perception/depth_eval/stereo_eval.hpp"

namespace {

cv::Mat readGray(const std::string& path, const std::string& flag) {
  cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw ptz::ConfigError("--" + flag + " '" + path + "': cannot read the image");
  return img;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ptz;
  using namespace ptz::perception;
  Params p("ptz-depth-eval",
           "Scores the matcher of ptz-depth on a rectified stereo pair with ground-truth "
           "disparity (bad = |d - gt| > 1 px, 10 px border ignored, unknown truth skipped, "
           "invalid counts as bad) and prints JSON.");
  p.add("left", "", "left (reference) image");
  p.add("right", "", "right image");
  p.add("gt", "",
        "ground-truth disparity of the left view: 8- or 16-bit PNG/PGM (0 = unknown) or PFM (inf "
        "= unknown)");
  p.add("gt_right", "", "ground truth of the right view, for the occlusion mask (optional)");
  p.add("scale", 0.0, "",
        "ground-truth value per pixel of disparity (0: the format's own, 1 for 8-bit and PFM, "
        "256 for 16-bit as KITTI)",
        Range::atLeast(0));
  p.add("border_px", 10, "px", "ignored border", Range::between(0, 10000));
  declareDepthParams(p);
  try {
    if (!p.parse(argc, argv)) return 0;
    for (const char* required : {"left", "right", "gt"}) {
      if (p.getString(required).empty()) {
        throw ConfigError(std::string("--") + required + " is required");
      }
    }
    const DepthParams dp = DepthParams::fromParams(p);
    const cv::Mat left = readGray(p.getString("left"), "left");
    const cv::Mat right = readGray(p.getString("right"), "right");
    if (left.size() != right.size()) throw ConfigError("--left and --right differ in size");
    std::string gt_format;
    const cv::Mat gt =
        loadGroundTruth(p.getString("gt"), p.getDouble("scale"), left.size(), &gt_format);
    const std::string gt_right_path = p.getString("gt_right");
    const cv::Mat gt_right =
        gt_right_path.empty() ? cv::Mat()
                              : loadGroundTruth(gt_right_path, p.getDouble("scale"), left.size());

    DisparityMatcher matcher(dp.matcher);
    const int min_d = dp.horopter.min_disparity_px;
    cv::Mat d16;
    matcher.compute(left, right, min_d, &d16);
    const StereoScore s = scoreDisparity(disparityToFloat(d16, min_d), gt,
                                         nonOccludedMask(gt, gt_right), p.getInt("border_px"));
    std::printf(
        "{\"mode\": \"%s\", \"wls\": %s, \"min_disparity_px\": %d, \"num_disparities\": %d, "
        "\"block_size_px\": %d, \"bad_all\": %.4f, \"bad_nonocc\": %.4f, "
        "\"invalid_fraction\": %.4f, \"known_px\": %lld, \"nonocc_px\": %lld, "
        "\"occlusion_from\": \"%s\", \"gt_format\": \"%s\"}\n",
        MatcherParams::modeName(dp.matcher.mode), dp.matcher.wls ? "true" : "false", min_d,
        dp.matcher.num_disparities,
        dp.matcher.mode == MatcherParams::Mode::kBm ? dp.matcher.block_size_px
                                                    : dp.matcher.sgbm_block_size_px,
        s.bad_all, s.bad_nonocc, s.invalid_fraction, static_cast<long long>(s.known_px),
        static_cast<long long>(s.nonocc_px),
        gt_right.empty() ? "left ground truth warped" : "left-right ground truth",
        gt_format.c_str());
    return 0;
  } catch (const ConfigError& e) {
    std::cerr << "ptz-depth-eval: " << e.what() << "\n";
    return 2;
  }
}
