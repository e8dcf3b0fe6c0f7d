// Foundation benchmark: render time of one stereo frame (capture: both cameras, noise) at VGA
// and 1080p on one thread and on all, and LCM delivery latency of raw and JPEG stereo frames
// between two processes. Medians and p99, with a baseline measured in the same run (a plain
// memcpy of a frame) to compare machines.
#include <opencv2/core.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "common/transport/transport.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "sim/simulator.hpp"
#include "support/child_process.hpp"
#include "support/lcm_wait.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double ms(Clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

ptz::sim::Scene defaultScene() {
  cv::FileStorage fs(PTZ_SOURCE_DIR "/config/sim_default.yaml", cv::FileStorage::READ);
  return ptz::sim::Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"], "default");
}

void report(const char* what, std::vector<double> v, const char* unit) {
  std::printf("%-44s median %8.3f %s   p99 %8.3f %s   (n = %zu)\n", what, ptz::percentile(v, 50),
              unit, ptz::percentile(v, 99), unit, v.size());
}

// Capture times (ms: both cameras rendered, noise added) of `frames` stereo frames of the
// default scenario, 30 frames/s of sim time, after one frame of warm-up (allocation, the first
// rays). moving: both heads pan, tilt and zoom every frame (new rays and background each frame);
// still: they stay home (the background drawn twice, then kept).
std::vector<double> timeCaptures(const ptz::StereoRig& rig, int frames, bool moving) {
  auto plant = ptz::defaultPlantParams();
  for (auto& a : plant.axis) {
    a.time_constant_s = 1e-4;
    a.max_rate_per_s = 1e6;
  }
  ptz::sim::Simulator sim(rig, defaultScene(), plant, 2.0, 1);
  std::vector<double> capture_ms;
  for (int i = 0; i <= frames; ++i) {
    const double t = i / 30.0;
    if (moving) {
      const ptz::PtzPose pose{0.4 * std::sin(0.7 * t), 0.1 * std::sin(1.3 * t),
                              2.0 + std::sin(0.9 * t)};
      int clamped = 0, rejected = 0;
      sim.command(t, pose, pose, &clamped, &rejected);
    }
    sim.advanceTo(t + 0.01);
    auto t0 = Clock::now();
    ptz::sim::SimFrame f = sim.capture();
    if (i > 0) capture_ms.push_back(ms(Clock::now() - t0));
  }
  return capture_ms;
}

void benchRender() {
  const int all_threads = cv::getNumThreads();
  struct Size {
    const char* name;
    int width, height, frames;
  };
  double vga_full_ms = 0;  // a VGA frame drawn whole on one thread, against the baseline
  for (const Size& size : {Size{"VGA", 640, 480, 200}, Size{"1080p", 1920, 1080, 100}}) {
    const ptz::StereoRig rig = ptz::StereoRig::makeDefault().atSize(size.width, size.height);
    for (bool moving : {true, false}) {
      double median_ms[2] = {0, 0};
      for (int threads : {1, all_threads}) {
        cv::setNumThreads(threads);
        const std::vector<double> v = timeCaptures(rig, size.frames, moving);
        const std::string what = std::string("render ") + size.name + " stereo, " +
                                 (moving ? "moving" : "still") + ", " + std::to_string(threads) +
                                 (threads == 1 ? " thread" : " threads");
        report(what.c_str(), v, "ms");
        median_ms[threads == 1 ? 0 : 1] = ptz::percentile(v, 50);
        std::printf("%-44s %.1f frames/s\n", "  = render rate at the median",
                    1000.0 / ptz::percentile(v, 50));
      }
      std::printf("%-44s %.2f x\n", "  speed-up, all threads / 1 thread",
                  median_ms[0] / median_ms[1]);
      if (moving && size.width == 640) vga_full_ms = median_ms[0];
    }
  }
  cv::setNumThreads(all_threads);

  // JPEG cost and the machine's baseline, VGA.
  ptz::sim::Simulator sim(ptz::StereoRig::makeDefault(), defaultScene(), ptz::defaultPlantParams(),
                          2.0, 1);
  std::vector<double> baseline_ms, jpeg_ms;
  std::vector<uint8_t> src(640 * 480 * 3 * 2, 7), dst(src.size());
  for (int i = 0; i < 200; ++i) {
    sim.advanceTo(i / 30.0);
    const ptz::sim::SimFrame f = sim.capture();
    auto j0 = Clock::now();
    auto jl = ptz::encodeImage(f.left, ptzstereo::image_t::ENCODING_JPEG, 90);
    auto jr = ptz::encodeImage(f.right, ptzstereo::image_t::ENCODING_JPEG, 90);
    jpeg_ms.push_back(ms(Clock::now() - j0));
    auto b0 = Clock::now();
    std::memcpy(dst.data(), src.data(), src.size());
    baseline_ms.push_back(ms(Clock::now() - b0));
    src[static_cast<size_t>(i)] = dst[static_cast<size_t>(i) + 1];  // keep the copy alive
  }
  report("JPEG q90 encode of both images (VGA)", jpeg_ms, "ms");
  report("baseline: memcpy of one raw VGA stereo frame", baseline_ms, "ms");
  std::printf("%-44s %.0f x\n", "  render VGA moving 1 thread / baseline",
              vga_full_ms / ptz::percentile(baseline_ms, 50));
}

struct Latency {
  std::vector<double> ms;
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    ms.push_back((ptz::wallUtime() - m->publish_utime) / 1000.0);
  }
};

void benchDelivery(const std::string& encoding) {
  lcm::LCM lcm(ptz::test::kTestUrl);
  Latency lat;
  lcm.subscribe("STEREO_FRAME", &Latency::onFrame, &lat);
  ptz::test::ChildProcess sim({PTZ_SIM_BIN, "--lcm-url", ptz::test::kTestUrl, "--frames", "300",
                               "--encoding", encoding, "--clock", "realtime"});
  ptz::test::handleUntil(
      lcm, [&] { return sim.wait(std::chrono::milliseconds(0)) >= 0; }, std::chrono::seconds(40));
  ptz::test::drain(lcm, std::chrono::milliseconds(500));
  const std::string what = "LCM delivery publish->receive, " + encoding;
  report(what.c_str(), lat.ms, "ms");
  std::printf("%-44s %zu of 300\n", "  frames received", lat.ms.size());
}

}  // namespace

int main(int argc, char** argv) {
  const bool lcm_too = argc > 1 && std::string(argv[1]) == "--with-lcm";
  benchRender();
  if (lcm_too) {
    benchDelivery("raw");
    benchDelivery("jpeg");
  } else {
    std::printf(
        "(LCM delivery: run with --with-lcm inside a private network namespace, as "
        "scripts/bench does)\n");
  }
  return 0;
}
