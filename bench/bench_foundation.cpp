// Foundation benchmark: render time of one VGA stereo frame (one core), and LCM delivery
// latency of raw and JPEG stereo frames between two processes. Medians and p99, with a baseline
// measured in the same run (a plain memcpy of a frame) to compare machines.
#include <opencv2/core.hpp>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "common/transport.hpp"
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

void benchRender() {
  cv::setNumThreads(1);
  ptz::sim::Simulator sim(ptz::StereoRig::makeDefault(), defaultScene(), ptz::defaultPlantParams(),
                          2.0, 1);
  std::vector<double> render_ms, baseline_ms, jpeg_ms;
  std::vector<uint8_t> src(640 * 480 * 3 * 2, 7), dst(src.size());
  for (int i = 0; i < 200; ++i) {
    sim.advanceTo(i / 30.0);
    auto t0 = Clock::now();
    ptz::sim::SimFrame f = sim.capture();
    auto t1 = Clock::now();
    render_ms.push_back(ms(t1 - t0));
    auto j0 = Clock::now();
    auto jl = ptz::encodeImage(f.left, ptzstereo::image_t::ENCODING_JPEG, 90);
    auto jr = ptz::encodeImage(f.right, ptzstereo::image_t::ENCODING_JPEG, 90);
    jpeg_ms.push_back(ms(Clock::now() - j0));
    auto b0 = Clock::now();
    std::memcpy(dst.data(), src.data(), src.size());
    baseline_ms.push_back(ms(Clock::now() - b0));
    src[static_cast<size_t>(i)] = dst[static_cast<size_t>(i) + 1];  // keep the copy alive
  }
  report("render VGA stereo frame (1 core)", render_ms, "ms");
  std::printf("%-44s %.1f frames/s\n", "  = render rate at the median",
              1000.0 / ptz::percentile(render_ms, 50));
  report("JPEG q90 encode of both images", jpeg_ms, "ms");
  report("baseline: memcpy of one raw stereo frame", baseline_ms, "ms");
  std::printf("%-44s %.0f x\n", "  render / baseline",
              ptz::percentile(render_ms, 50) / ptz::percentile(baseline_ms, 50));
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
