// ptz-depth's frame on rendered stereo frames of the default scenario at VGA and 1080p, with
// OpenCV's threads on all cores (or --threads): the bare cv::StereoBM::compute on the pair the full
// frame matches (a decimated pair when the frame is wider than match_max_width_px, and then also
// the bare matcher at full size), the full frame (rectify + match + reproject + outlier filter +
// cloud) and its steps, and the full frame without the pixel-grid outlier filter; medians and
// p99, all interleaved in one run.
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "bench_util.hpp"
#include "common/config.hpp"
#include "common/transport/transport.hpp"
#include "perception/depth/cloud.hpp"
#include "perception/depth/depth.hpp"
#include "sim/simulator.hpp"

using ptz::bench::Clock;
using ptz::bench::ms;
using ptz::bench::report;
namespace perception = ptz::perception;

namespace {

struct Frame {
  cv::Mat left, right;
  ptz::PtzPose left_pose, right_pose;
};

// The default scenario's first frames at 30 Hz. Rendered once and used in turn: a 1080p frame
// takes ~0.5 s to render, and more frames than the caches hold keep each one cold, as a freshly
// decoded frame is.
std::vector<Frame> render(const ptz::StereoRig& rig, const ptz::sim::Scene& scene, int count) {
  ptz::sim::Simulator sim(rig, scene, ptz::defaultPlantParams(), 2.0, 1);
  std::vector<Frame> frames;
  for (int i = 0; i < count; ++i) {
    sim.advanceTo(i / 30.0);
    ptz::sim::SimFrame f = sim.capture();
    frames.push_back({f.left, f.right, f.left_pose, f.right_pose});
  }
  return frames;
}

double ratio(const std::vector<double>& a, const std::vector<double>& b, double p) {
  return ptz::percentile(a, p) / ptz::percentile(b, p);
}

bool run(const std::string& name, const ptz::StereoRig& rig, const std::vector<Frame>& frames,
         int iterations, const perception::DepthParams& params,
         const perception::CloudParams& cloud_params) {
  perception::DepthEstimator estimator(rig, params);
  // The same without the pixel-grid outlier filter: what the filter costs, in the same run.
  perception::DepthParams unfiltered_params = params;
  unfiltered_params.outlier_stddev_mult = 0;
  perception::DepthEstimator unfiltered(rig, unfiltered_params);
  // The same matcher called bare, on the pair the full frame matched and, when that is
  // decimated, on the full-size pair (rectified here, untimed).
  perception::DisparityMatcher bare(params.matcher), bare_full_size(params.matcher);
  const bool decimated = estimator.decimation() > 1;
  perception::Rectifier full_size(rig);
  // At full size the bare matcher takes several times the frame: every 4th iteration.
  constexpr int kFullSizeEvery = 4;

  std::vector<double> full_ms, bare_ms, bare_full_size_ms, unfiltered_ms, cloud_ms;
  std::vector<double> rectify_ms, match_ms, reproject_ms, outliers_ms;
  size_t points = 0;
  // Frames, clouds and their makers reused, as ptz-depth does.
  perception::DepthFrame out, plain;
  perception::CloudMaker cloud_maker(cloud_params), plain_cloud_maker(cloud_params);
  ptzstereo::point_cloud_t cloud, plain_cloud;
  cv::Mat disparity, grey[2], rect[2];
  std::string why;
  for (int i = 0; i < iterations; ++i) {
    const Frame& f = frames[static_cast<size_t>(i) % frames.size()];
    // The frame without the grid filter, before or after (alternately: caches favour the second).
    auto unfilteredFrame = [&] {
      const auto u0 = Clock::now();
      if (!unfiltered.process(f.left, f.right, f.left_pose, f.right_pose, std::nullopt, &plain,
                              &why)) {
        return false;
      }
      plain_cloud_maker.make(plain.points_head_m, plain.colours_bgr, &plain_cloud);
      unfiltered_ms.push_back(ms(Clock::now() - u0));
      return true;
    };
    if (i % 2 == 0 && !unfilteredFrame()) break;
    const auto t0 = Clock::now();
    if (!estimator.process(f.left, f.right, f.left_pose, f.right_pose, std::nullopt, &out, &why)) {
      break;
    }
    const auto t1 = Clock::now();
    cloud_maker.make(out.points_head_m, out.colours_bgr, &cloud);
    const auto t2 = Clock::now();
    full_ms.push_back(ms(t2 - t0));
    cloud_ms.push_back(ms(t2 - t1));
    rectify_ms.push_back(out.times.rectify_ms);
    match_ms.push_back(out.times.match_ms);
    reproject_ms.push_back(out.times.reproject_ms);
    outliers_ms.push_back(out.times.outliers_ms);
    points += static_cast<size_t>(cloud.width);
    if (i % 2 == 1 && !unfilteredFrame()) break;

    const auto b0 = Clock::now();
    bare.compute(estimator.matchedLeft(), estimator.matchedRight(), out.min_disparity_px,
                 &disparity);
    bare_ms.push_back(ms(Clock::now() - b0));

    if (decimated && i % kFullSizeEvery == 0) {
      if (!full_size.update(f.left_pose, f.right_pose, &why)) break;
      const perception::Rectification& r = full_size.current();
      cv::cvtColor(f.left, grey[0], cv::COLOR_BGR2GRAY);
      cv::cvtColor(f.right, grey[1], cv::COLOR_BGR2GRAY);
      cv::remap(grey[0], rect[0], r.map_left[0], r.map_left[1], cv::INTER_LINEAR);
      cv::remap(grey[1], rect[1], r.map_right[0], r.map_right[1], cv::INTER_LINEAR);
      // The same search range in full-size pixels would be decimation times as wide; the
      // matcher's own (num_disparities) is what the frame would cost undecimated.
      const int min_d =
          perception::chooseMinDisparity(r, params.horopter, params.matcher.num_disparities, {});
      const auto c0 = Clock::now();
      bare_full_size.compute(rect[0], rect[1], min_d, &disparity);
      bare_full_size_ms.push_back(ms(Clock::now() - c0));
    }
  }
  if (!why.empty()) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), why.c_str());
    return false;
  }
  const cv::Size matched = estimator.matchedLeft().size();
  const bool bm = params.matcher.mode == perception::MatcherParams::Mode::kBm;
  std::printf(
      "\n== %s %dx%d, matched at %dx%d (decimation %d), %s, %d disparities, block %d px, %d "
      "OpenCV threads, %zu rendered frames in turn\n",
      name.c_str(), rig.left.width, rig.left.height, matched.width, matched.height,
      estimator.decimation(), perception::MatcherParams::modeName(params.matcher.mode),
      params.matcher.num_disparities,
      bm ? params.matcher.block_size_px : params.matcher.sgbm_block_size_px, cv::getNumThreads(),
      frames.size());
  std::ostringstream bare_name;
  bare_name << (bm ? "bare cv::StereoBM::compute" : "bare cv::StereoSGBM::compute")
            << " on the matched pair (" << matched.width << "x" << matched.height << ")";
  report(bare_name.str().c_str(), bare_ms);
  report("full ptz-depth frame (rectify+match+reproject+cloud)", full_ms);
  report("  rectify: grey, decimate, remap; sample colours", rectify_ms);
  report("  match", match_ms);
  report("  reproject the samples", reproject_ms);
  report("  grid outlier filter", outliers_ms);
  report("  cloud (voxel grid, PCL SOR if on)", cloud_ms);
  report("full frame without the pixel-grid outlier filter", unfiltered_ms);
  if (decimated) {
    std::ostringstream full_name;
    full_name << "bare matcher at full size (" << rig.left.width << "x" << rig.left.height
              << ", every " << kFullSizeEvery << "th)";
    report(full_name.str().c_str(), bare_full_size_ms);
  }
  std::printf("%-52s %.3f x (p99: %.3f x)\n", "  full / bare on the matched pair (medians)",
              ratio(full_ms, bare_ms, 50), ratio(full_ms, bare_ms, 99));
  // For scripts/bench's table: the size, full and bare median / p99 (ms), the ratios.
  std::printf("DEPTH-ROW %s %.1f/%.1f %.1f/%.1f %.2f %.2f\n", name.c_str(),
              ptz::percentile(full_ms, 50), ptz::percentile(full_ms, 99),
              ptz::percentile(bare_ms, 50), ptz::percentile(bare_ms, 99),
              ratio(full_ms, bare_ms, 50), ratio(full_ms, bare_ms, 99));
  if (decimated) {
    std::printf("%-52s %.3f x\n", "  full / bare at full size (medians)",
                ratio(full_ms, bare_full_size_ms, 50));
  }
  std::printf("%-52s %.3f x\n", "  full / without the grid filter (medians)",
              ratio(full_ms, unfiltered_ms, 50));
  std::printf("%-52s %.1f\n", "  full frames/s (median)", 1000.0 / ptz::percentile(full_ms, 50));
  std::printf("%-52s %zu\n", "  points per cloud (mean)", points / full_ms.size());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  ptz::Params p("ptz_bench_depth", "Times ptz-depth's frame against the bare StereoBM.");
  p.add("frames", 200, "", "frames to time at each size", ptz::Range::atLeast(1));
  p.add("sizes", "vga,1080p", "image sizes to time: vga, 1080p or both (comma-separated)");
  p.add("threads", 0, "", "OpenCV's threads (0: its default, all cores; 1: a slower machine)",
        ptz::Range::atLeast(0));
  perception::declareDepthParams(p);
  perception::declareCloudParams(p);
  if (!p.parse(argc, argv)) return 0;
  if (p.getInt("threads") > 0) cv::setNumThreads(p.getInt("threads"));
  cv::FileStorage cfg(PTZ_SOURCE_DIR "/config/sim_default.yaml", cv::FileStorage::READ);
  const auto scene = ptz::sim::Scene::fromConfig(cfg["scene"], cfg["objects"], cfg["chessboard"],
                                                 "sim_default.yaml");
  // The process's defaults (BM, 64 disparities) unless flags say otherwise.
  const perception::DepthParams params = perception::DepthParams::fromParams(p);
  const perception::CloudParams cloud_params = perception::CloudParams::fromParams(p);
  const std::string sizes = p.getString("sizes");
  struct Size {
    const char* name;
    int width_px, height_px, rendered;
  };
  for (const Size& s : {Size{"vga", 640, 480, 30}, Size{"1080p", 1920, 1080, 10}}) {
    if (sizes.find(s.name) == std::string::npos) continue;
    const ptz::StereoRig rig = ptz::StereoRig::makeDefault().atSize(s.width_px, s.height_px);
    if (!run(s.name, rig, render(rig, scene, s.rendered), p.getInt("frames"), params,
             cloud_params)) {
      return 1;
    }
  }
  return 0;
}
