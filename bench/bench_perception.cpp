// ptz-detect's library on rendered VGA stereo frames of the default scenario, one core: time per
// stereo frame (both images: detection, association, triangulation), median and p99, with JPEG
// decoding measured separately and a memcpy baseline from the same run.
#include <opencv2/core.hpp>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <vector>

#include "bench_util.hpp"
#include "common/transport/transport.hpp"
#include "perception/detection/detector.hpp"
#include "perception/detection/stereo.hpp"
#include "sim/simulator.hpp"

using ptz::bench::Clock;
using ptz::bench::ms;
using ptz::bench::report;

int main() {
  cv::setNumThreads(1);
  cv::FileStorage sim_cfg(PTZ_SOURCE_DIR "/config/sim_default.yaml", cv::FileStorage::READ);
  cv::FileStorage det_cfg(PTZ_SOURCE_DIR "/config/detect_default.yaml", cv::FileStorage::READ);
  const auto scene = ptz::sim::Scene::fromConfig(sim_cfg["scene"], sim_cfg["objects"],
                                                 sim_cfg["chessboard"], "sim_default.yaml");
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ptz::sim::Simulator sim(rig, scene, ptz::defaultPlantParams(), 2.0, 1);
  const ptz::perception::Detector detector(
      ptz::perception::DetectorParams::fromConfig(det_cfg["classes"], "detect_default.yaml"));
  std::vector<double> detect_ms, decode_ms, baseline_ms;
  std::vector<uint8_t> src(640 * 480 * 3 * 2, 7), dst(src.size());
  int found = 0;
  for (int i = 0; i < 300; ++i) {
    sim.advanceTo(i / 30.0);
    const ptz::sim::SimFrame f = sim.capture();
    const auto jl = ptz::encodeImage(f.left, ptzstereo::image_t::ENCODING_JPEG, 90);
    const auto jr = ptz::encodeImage(f.right, ptzstereo::image_t::ENCODING_JPEG, 90);
    cv::Mat l, r;
    std::string err;
    auto d0 = Clock::now();
    ptz::decodeImage(jl, &l, &err);
    ptz::decodeImage(jr, &r, &err);
    decode_ms.push_back(ms(Clock::now() - d0));
    auto t0 = Clock::now();
    const auto lr = detector.detect(l), rr = detector.detect(r);
    const auto objects = ptz::perception::associate(lr, rr, rig.view(ptz::Side::kLeft, f.left_pose),
                                                    rig.view(ptz::Side::kRight, f.right_pose), {});
    detect_ms.push_back(ms(Clock::now() - t0));
    found += objects.empty() ? 0 : 1;
    auto b0 = Clock::now();
    std::memcpy(dst.data(), src.data(), src.size());
    baseline_ms.push_back(ms(Clock::now() - b0));
    src[static_cast<size_t>(i)] = dst[static_cast<size_t>(i) + 1];
  }
  report("detect + associate + triangulate, stereo frame", detect_ms);
  report("JPEG decode of both images", decode_ms);
  report("baseline: memcpy of one raw stereo frame", baseline_ms);
  std::printf("%-48s %.0f x\n", "  detect / baseline",
              ptz::percentile(detect_ms, 50) / ptz::percentile(baseline_ms, 50));
  std::printf("frames with at least one stereo object: %d of 300\n", found);
  return 0;
}
