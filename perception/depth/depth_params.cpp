// The parameters of ptz-depth and ptz-depth-eval: declared once, read once.
#include "common/config.hpp"
#include "perception/depth/depth.hpp"

namespace ptz::perception {

void declareDepthParams(Params& p) {
  p.add("mode", "bm", "matcher: bm (the paper's block matching) or sgbm (quality mode)");
  p.add("full_width", false, "pad the images so the left edge is matched too");
  p.add("wls", false, "filter the disparity with ximgproc's WLS filter (fills holes)");
  p.add("num_disparities", 64, "px",
        "width of the disparity search range (pixels of the matched pair), a multiple of 16",
        Range::between(16, 1024));
  p.add("min_disparity_px", 0, "px",
        "start of the search range (pixels of the matched pair) when neither target nor "
        "horopter_far_m sets it",
        Range::between(-4096, 4096));
  p.add("horopter_far_m", 10.0, "m",
        "without a target the search range starts at this depth's disparity (<= 0: "
        "min_disparity_px)");
  p.add("follow_target", true, "centre the search range on the OBJECT_POSE target's disparity");
  p.add("block_size_px", 11, "px", "BM: SAD window (odd)", Range::between(5, 255));
  p.add("sgbm_block_size_px", 3, "px", "SGBM: matched block size (odd)", Range::between(1, 255));
  p.add("prefilter_size_px", 7, "px", "BM: window of the normalising pre-filter (odd)",
        Range::between(5, 255));
  p.add("prefilter_cap", 31, "", "clip of the pre-filtered image", Range::between(1, 63));
  p.add("texture_threshold", 10, "", "BM: least texture in the window", Range::atLeast(0));
  p.add("uniqueness_pct", 15, "%", "best match cost this much below the second best",
        Range::between(0, 100));
  p.add("speckle_window_px", 100, "px", "largest speckle removed (0: off)", Range::atLeast(0));
  p.add("speckle_range_px", 2, "px", "disparity variation inside a speckle", Range::atLeast(0));
  p.add("lr_max_diff_px", 1, "px", "left-right consistency tolerance (< 0: off)",
        Range::atMost(4096));
  p.add("wls_lambda", 8000.0, "", "WLS smoothness", Range::atLeast(0));
  p.add("wls_sigma", 1.5, "", "WLS colour sensitivity", Range::above(0));
  p.add("min_depth_m", 0.3, "m", "nearest reconstructed depth", Range::above(0));
  p.add("max_depth_m", 20.0, "m", "farthest reconstructed depth", Range::above(0));
  p.addOrder("min_depth_m", "max_depth_m");
  p.add("cloud_stride_px", 4, "px",
        "reproject every n-th pixel of the matched pair in x and y (the voxel grid would merge "
        "them anyway)",
        Range::between(1, 1000));
  p.add("match_max_width_px", 1000, "px",
        "wider frames are matched decimated by the smallest integer factor that brings them to "
        "at most this width (1080p: at 960x540; 0: never)",
        Range::atLeast(0));
  p.add("outlier_stddev_mult", 1.0, "",
        "drop points whose distance to their nearer pixel-grid neighbour in each direction "
        "(mean, relative to range) is this many standard deviations above the frame's mean "
        "(0: off)",
        Range::atLeast(0));
}

DepthParams DepthParams::fromParams(const Params& p) {
  DepthParams d;
  MatcherParams& m = d.matcher;
  if (p.getString("mode") != "bm" && p.getString("mode") != "sgbm") {
    throw p.invalid("mode", "must be bm or sgbm");
  }
  m.mode = MatcherParams::parseMode(p.getString("mode"));
  m.wls = p.getBool("wls");
  m.full_width = p.getBool("full_width");
  m.num_disparities = p.getInt("num_disparities");
  m.block_size_px = p.getInt("block_size_px");
  m.sgbm_block_size_px = p.getInt("sgbm_block_size_px");
  m.prefilter_size_px = p.getInt("prefilter_size_px");
  m.prefilter_cap = p.getInt("prefilter_cap");
  m.texture_threshold = p.getInt("texture_threshold");
  m.uniqueness_pct = p.getInt("uniqueness_pct");
  m.speckle_window_px = p.getInt("speckle_window_px");
  m.speckle_range_px = p.getInt("speckle_range_px");
  m.lr_max_diff_px = p.getInt("lr_max_diff_px");
  m.wls_lambda = p.getDouble("wls_lambda");
  m.wls_sigma = p.getDouble("wls_sigma");
  d.horopter.follow_target = p.getBool("follow_target");
  d.horopter.far_depth_m = p.getDouble("horopter_far_m");
  d.horopter.min_disparity_px = p.getInt("min_disparity_px");
  d.min_depth_m = p.getDouble("min_depth_m");
  d.max_depth_m = p.getDouble("max_depth_m");
  d.cloud_stride_px = p.getInt("cloud_stride_px");
  d.match_max_width_px = p.getInt("match_max_width_px");
  d.outlier_stddev_mult = p.getDouble("outlier_stddev_mult");
  // The ranges and the depths' order are the declarations'; what they cannot say:
  if (m.num_disparities % 16 != 0) throw p.invalid("num_disparities", "must be a multiple of 16");
  for (const char* odd : {"block_size_px", "sgbm_block_size_px", "prefilter_size_px"}) {
    if (p.getInt(odd) % 2 == 0) throw p.invalid(odd, "must be odd");
  }
  return d;
}

}  // namespace ptz::perception
