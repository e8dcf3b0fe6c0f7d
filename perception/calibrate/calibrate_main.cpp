// ptz-calibrate: stereo calibration from chessboard views into the rig file every process loads.
// Sources: left/right image files (a folder or a list), or STEREO_FRAME over LCM (views kept when
// the board is in both images and adds coverage). Exit 2 with the files named on bad input. The
// work is the library's (calibrate_tool.hpp); this main reads the flags and, live, the frames.
#include <cstdio>
#include <string>

#include "common/transport/transport.hpp"
#include "perception/calibrate/calibrate_tool.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::perception {
namespace {

int runLive(const Params& p, lcm::LCM& lcm) {
  checkOutputs(p);
  StatusReporter status(&lcm, p, "ptz-calibrate");
  LiveViews live(p);
  const std::string ch = channel(p, channels::kStereoFrame);
  RateLimitedLog log;
  auto drop = [&](int64_t seq, const std::string& reason, const std::string& why) {
    status.countDropped(ch, reason);
    log.warn(reason, "ptz-calibrate: dropped frame " + std::to_string(seq) + ": " + why);
  };
  // The board search takes longer than a frame period: work on the newest frame.
  SafeSubscription<ptzstereo::stereo_frame_t> frames(
      lcm, ch, status,
      [&](const std::string&, const ptzstereo::stereo_frame_t& m) {
        status.countIn(ch, (wallUtime() - m.utime) / 1000.0);
        if (const std::string why = live.notAtHome(m); !why.empty()) {
          drop(m.seq, "not_at_home", why);
          return;
        }
        cv::Mat left, right;
        std::string error;
        if (!decodeImage(m.left, &left, &error) || !decodeImage(m.right, &right, &error)) {
          drop(m.seq, "bad_image", error);
          return;
        }
        status.increment(std::string("frames_") + resultName(live.offer(left, right, m.seq)));
        if (live.done()) StopFlag::request();
      },
      Delivery::kNewest);
  std::printf("ptz-calibrate: listening on %s for the board %s; %zu views wanted (Ctrl-C ends)\n",
              ch.c_str(), boardOf(p).text().c_str(), live.target());
  serveUntilStopped(lcm, status);
  std::printf("%zu views kept; coverage %s\n", live.collector().views().size(),
              live.collector().progressText().c_str());
  calibrateAndWrite(p, live.collector().views(), live.collector().imageSize());
  return 0;
}

}  // namespace
}  // namespace ptz::perception

int main(int argc, char** argv) {
  ptz::Params p("ptz-calibrate",
                "Stereo calibration from chessboard views (image pairs, or STEREO_FRAME live): "
                "intrinsics (5-coefficient Brown), R, T, E, F, rectification, per-view errors; "
                "writes the rig file.");
  ptz::perception::declareCalibrateParams(p);
  ptz::addTransportParams(p);
  try {
    if (!p.parse(argc, argv)) return 0;
    // Image files need no network: only the live source opens LCM.
    if (p.getString("source") == "lcm")
      return ptz::runProcess(argc, argv, p, ptz::perception::runLive);
    if (p.getString("source") != "files") {
      throw p.invalid("source", "must be files or lcm");
    }
    return ptz::perception::runFiles(p);
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-calibrate: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptz-calibrate: stopped: %s\n", e.what());
    return 3;
  }
}
