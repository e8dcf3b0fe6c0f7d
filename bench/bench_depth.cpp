// ptz-depth's frame on rendered VGA stereo frames of the default scenario, 64 disparities, with
// OpenCV's threads on all cores: the bare cv::StereoBM::compute on the same rectified pair, and
// the full frame (rectify + match + reproject + outlier filter + cloud), median and p99, and the
// full frame without the pixel-grid outlier filter.
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <vector>

#include "bench_util.hpp"
#include "common/config.hpp"
#include "common/transport.hpp"
#include "perception/depth/cloud.hpp"
#include "perception/depth/depth.hpp"
#include "sim/simulator.hpp"

using ptz::bench::Clock;
using ptz::bench::ms;
using ptz::bench::report;

int main(int argc, char** argv) {
  ptz::Params p("ptz_bench_depth", "Times ptz-depth's frame against the bare StereoBM.");
  p.add("frames", 200, "", "frames to time", ptz::Range::atLeast(1));
  ptz::perception::declareDepthParams(p);
  ptz::perception::declareCloudParams(p);
  if (!p.parse(argc, argv)) return 0;
  const int frames = p.getInt("frames");
  cv::FileStorage cfg(PTZ_SOURCE_DIR "/config/sim_default.yaml", cv::FileStorage::READ);
  const auto scene = ptz::sim::Scene::fromConfig(cfg["scene"], cfg["objects"], cfg["chessboard"],
                                                 "sim_default.yaml");
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ptz::sim::Simulator sim(rig, scene, ptz::defaultPlantParams(), 2.0, 1);
  namespace perception = ptz::perception;
  // The process's defaults (BM, 64 disparities) unless flags say otherwise.
  const perception::DepthParams params = perception::DepthParams::fromParams(p);
  const perception::CloudParams cloud_params = perception::CloudParams::fromParams(p);
  perception::DepthEstimator estimator(rig, params);
  // The same without the pixel-grid outlier filter: what the filter costs, in the same run.
  perception::DepthParams unfiltered_params = params;
  unfiltered_params.outlier_stddev_mult = 0;
  perception::DepthEstimator unfiltered(rig, unfiltered_params);
  // The same BM, called bare.
  perception::MatcherParams bare_params = params.matcher;
  perception::DisparityMatcher bare(bare_params);

  std::vector<double> full_ms, bare_ms, cloud_ms, unfiltered_ms;
  size_t points = 0;
  for (int i = 0; i < frames; ++i) {
    sim.advanceTo(i / 30.0);
    const ptz::sim::SimFrame f = sim.capture();
    perception::DepthFrame out, plain;
    std::string why;
    // The frame without the grid filter, before or after (alternately: caches favour the second).
    auto unfilteredFrame = [&] {
      const auto u0 = Clock::now();
      if (!unfiltered.process(f.left, f.right, f.left_pose, f.right_pose, std::nullopt, &plain,
                              &why)) {
        return false;
      }
      perception::makeCloud(plain.points_head_m, plain.colours_bgr, cloud_params);
      unfiltered_ms.push_back(ms(Clock::now() - u0));
      return true;
    };
    if (i % 2 == 0 && !unfilteredFrame()) {
      std::fprintf(stderr, "%s\n", why.c_str());
      return 1;
    }
    const auto t0 = Clock::now();
    if (!estimator.process(f.left, f.right, f.left_pose, f.right_pose, std::nullopt, &out, &why)) {
      std::fprintf(stderr, "%s\n", why.c_str());
      return 1;
    }
    const auto t1 = Clock::now();
    const ptzstereo::point_cloud_t cloud =
        perception::makeCloud(out.points_head_m, out.colours_bgr, cloud_params);
    const auto t2 = Clock::now();
    full_ms.push_back(ms(t2 - t0));
    cloud_ms.push_back(ms(t2 - t1));
    points += static_cast<size_t>(cloud.width);
    if (i % 2 == 1 && !unfilteredFrame()) {
      std::fprintf(stderr, "%s\n", why.c_str());
      return 1;
    }

    // The rectified pair the full frame matched, then the bare StereoBM on it.
    const perception::Rectification& r = estimator.rectifier().current();
    cv::Mat left_gray, right_gray, right_rect, disparity;
    cv::cvtColor(out.left_rectified_bgr, left_gray, cv::COLOR_BGR2GRAY);
    cv::cvtColor(f.right, right_gray, cv::COLOR_BGR2GRAY);
    cv::remap(right_gray, right_rect, r.map_right[0], r.map_right[1], cv::INTER_LINEAR);
    const auto b0 = Clock::now();
    bare.compute(left_gray, right_rect, out.min_disparity_px, &disparity);
    bare_ms.push_back(ms(Clock::now() - b0));
  }
  std::printf("VGA, %d disparities, block %d px, %d OpenCV threads\n",
              params.matcher.num_disparities, params.matcher.block_size_px, cv::getNumThreads());
  const bool bm = params.matcher.mode == perception::MatcherParams::Mode::kBm;
  report(bm ? "bare cv::StereoBM::compute (rectified pair)"
            : "bare cv::StereoSGBM::compute (rectified pair)",
         bare_ms);
  report("full ptz-depth frame (rectify+match+reproject+cloud)", full_ms);
  report("  of which the cloud (voxel grid, PCL SOR if on)", cloud_ms);
  report("full frame without the pixel-grid outlier filter", unfiltered_ms);
  std::printf("%-52s %.2f x\n", "  full / bare (medians)",
              ptz::percentile(full_ms, 50) / ptz::percentile(bare_ms, 50));
  std::printf("%-52s %.2f x\n", "  full / without the grid filter (medians)",
              ptz::percentile(full_ms, 50) / ptz::percentile(unfiltered_ms, 50));
  std::printf("%-52s %.1f\n", "  full frames/s (median)", 1000.0 / ptz::percentile(full_ms, 50));
  std::printf("%-52s %zu\n", "  points per cloud (mean)", points / full_ms.size());
  return 0;
}
