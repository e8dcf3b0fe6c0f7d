// ptz-calibrate's work on OpenCV's 13 sample pairs, end to end (read, find the board in 26 images,
// mono + stereo calibration, rectification, write the rig file): median and p99 of several runs,
// on all cores and on one; the detection's share measured separately. Goal: <= 5 s.
#include <opencv2/core.hpp>

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "common/transport/transport.hpp"
#include "perception/calibrate/calibration.hpp"
#include "perception/calibrate/calibration_files.hpp"

namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

void report(const char* what, const std::vector<double>& v) {
  std::printf("%-52s median %6.3f s   p99 %6.3f s   (n = %zu)\n", what, ptz::percentile(v, 50),
              ptz::percentile(v, 99), v.size());
}

}  // namespace

int main() {
  const char* env = std::getenv("PTZ_DATA_DIR");
  const std::string dir =
      std::string(env && *env ? env : PTZ_SOURCE_DIR "/../shared/data") + "/opencv_stereo_calib";
  const ptz::perception::BoardSpec board{9, 6, 0.025};
  const std::string output = "/tmp/ptz_bench_calibration_rig.yaml";
  for (int threads : {cv::getNumThreads(), 1}) {
    cv::setNumThreads(threads);
    std::vector<double> total_s, detect_s;
    for (int run = 0; run < 5; ++run) {
      const auto t0 = Clock::now();
      const auto detected = ptz::perception::detectPairs(
          ptz::perception::pairsFromFolder(dir, "left", "right"), board);
      const auto t1 = Clock::now();
      const auto c =
          ptz::perception::calibrateStereo(detected.views, board, detected.image_size, {});
      ptz::perception::saveCalibration(output, c.toRig(), c);
      total_s.push_back(seconds(Clock::now() - t0));
      detect_s.push_back(seconds(t1 - t0));
    }
    const std::string suffix = ", " + std::to_string(threads) + " thread(s)";
    report(("13 sample pairs end to end" + suffix).c_str(), total_s);
    report(("  of which reading + board detection" + suffix).c_str(), detect_s);
  }
  return 0;
}
