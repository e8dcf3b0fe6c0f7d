// ptz-calibrate: stereo calibration from chessboard views into the rig file every process loads.
// Sources: left/right image files (a folder or a list), or STEREO_FRAME over LCM (views kept when
// the board is in both images and adds coverage). Exit 2 with the files named on bad input.
#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cstdio>
#include <memory>

#include "perception/calibration.hpp"
#include "perception/calibration_files.hpp"
#include "perception/calibration_live.hpp"
#include "ptz/transport.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::perception {
namespace {

void declare(Params& p) {
  p.add("source", "files", "files (images_dir or image_list) or lcm (STEREO_FRAME, live)");
  p.add("images_dir", "", "folder of image pairs <left_prefix>X / <right_prefix>X");
  p.add("left_prefix", "left", "file-name prefix of the left images in images_dir");
  p.add("right_prefix", "right", "file-name prefix of the right images in images_dir");
  p.add("image_list", "", "text file of 'left_path right_path' lines (instead of images_dir)");
  p.add("board_cols", 9, "", "inner corners along a board row (squares - 1)");
  p.add("board_rows", 6, "", "inner corners along a board column (squares - 1)");
  p.add("square_m", 0.025, "m", "side of a board square");
  p.add("output", "rig_calibrated.yaml", "rig file to write (StereoRig + calibration report)");
  p.add("camera_info_dir", "", "also write ROS camera_info left.yaml/right.yaml here; empty: no");
  p.add("zoom", 1.0, "", "zoom position of both cameras in the images (the zoom table entry)");
  p.add("min_views", 8, "", "fewest views with the board in both images");
  p.add("max_view_error_px", 1.0, "px", "per-view RMS above which a view is an outlier");
  p.add("drop_outliers", false, "recalibrate without the outlier views (else only report them)");
  p.add("min_tilt_deg", 10.0, "deg", "some view must tilt the board at least this much");
  p.add("refine_intrinsics", true,
        "refine the intrinsics jointly with R, T in the stereo fit (false: keep the mono ones)");
  p.add("rectify_alpha", 0.0, "", "stereoRectify alpha: 0 valid pixels only, 1 all pixels");
  p.add("target_views", 20, "", "lcm: stop after keeping this many views (or on SIGINT)");
  p.add("min_coverage_distance", 0.2, "",
        "lcm: L1 distance in (x, y, size, skew) a view needs from every kept one");
  p.add("save_views_dir", "", "lcm: also write the kept views as leftNNN.png/rightNNN.png here");
  addTransportParams(p);
}

BoardSpec boardOf(const Params& p) {
  BoardSpec board{p.getInt("board_cols"), p.getInt("board_rows"), p.getDouble("square_m")};
  if (board.inner_cols < 2 || board.inner_rows < 2 || board.square_m <= 0) {
    throw ConfigError("--board-cols and --board-rows must be >= 2 and --square-m > 0");
  }
  return board;
}

StereoOptions optionsOf(const Params& p) {
  StereoOptions o;
  o.min_views = p.getInt("min_views");
  o.max_view_error_px = p.getDouble("max_view_error_px");
  o.drop_outliers = p.getBool("drop_outliers");
  o.min_tilt_deg = p.getDouble("min_tilt_deg");
  o.rectify_alpha = p.getDouble("rectify_alpha");
  o.refine_intrinsics = p.getBool("refine_intrinsics");
  return o;
}

void printReport(const StereoCalibration& c) {
  for (const auto& v : c.views) {
    std::printf("  %s / %s: %.3f / %.3f px, board tilt %.0f deg\n", v.left_name.c_str(),
                v.right_name.c_str(), v.left_rms_px, v.right_rms_px, v.left_tilt_deg);
  }
  for (const auto& o : c.outliers) std::printf("outlier: %s\n", o.c_str());
  for (const auto& d : c.dropped)
    std::printf("dropped: %s (%s)\n", d.name.c_str(), d.reason.c_str());
  std::printf("RMS left %.3f px, right %.3f px, stereo %.3f px; rectified |y_l - y_r| %.3f px\n",
              c.left.rms_px, c.right.rms_px, c.stereo_rms_px, c.rectified_epipolar_px);
  std::printf("baseline %.5f m (%.4f squares), %zu views used\n", cv::norm(c.T),
              cv::norm(c.T) / c.board.square_m, c.views.size());
}

// Calibrates, prints the report and writes the output files.
void calibrateAndWrite(const Params& p, const std::vector<ViewPair>& views, cv::Size size) {
  const StereoCalibration c = calibrateStereo(views, boardOf(p), size, optionsOf(p));
  printReport(c);
  saveCalibration(p.getString("output"), c.toRig(p.getDouble("zoom")), c);
  std::printf("wrote %s\n", p.getString("output").c_str());
  const std::string info_dir = p.getString("camera_info_dir");
  if (!info_dir.empty()) {
    saveCameraInfo(info_dir + "/left.yaml", c, Side::kLeft);
    saveCameraInfo(info_dir + "/right.yaml", c, Side::kRight);
    std::printf("wrote %s/left.yaml, %s/right.yaml\n", info_dir.c_str(), info_dir.c_str());
  }
}

int runFiles(const Params& p) {
  const auto t0 = std::chrono::steady_clock::now();
  const BoardSpec board = boardOf(p);
  std::vector<ImagePair> pairs;
  if (!p.getString("image_list").empty()) {
    pairs = pairsFromList(p.getString("image_list"));
  } else if (!p.getString("images_dir").empty()) {
    pairs = pairsFromFolder(p.getString("images_dir"), p.getString("left_prefix"),
                            p.getString("right_prefix"));
  } else {
    throw ConfigError("give --images-dir FOLDER or --image-list FILE (see ptz-calibrate --help)");
  }
  const DetectedViews detected = detectPairs(pairs, board);
  for (const auto& s : detected.skipped) std::printf("skipped: %s\n", s.c_str());
  std::printf("board %s found in both images of %zu of %zu pairs\n", board.text().c_str(),
              detected.views.size(), pairs.size());
  calibrateAndWrite(p, detected.views, detected.image_size);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%.2f s\n", s);
  return 0;
}

int runLive(const Params& p, lcm::LCM& lcm) {
  StatusReporter status(&lcm, p, "ptz-calibrate");
  LiveCollector collector(boardOf(p), p.getDouble("min_coverage_distance"));
  const size_t target = static_cast<size_t>(std::max(1, p.getInt("target_views")));
  const std::string ch = channel(p, channels::kStereoFrame),
                    save_dir = p.getString("save_views_dir");
  RateLimitedLog log;
  // A queue of one: the board search takes longer than a frame period; work on the newest.
  SafeSubscription<ptzstereo::stereo_frame_t> frames(
      lcm, ch, status,
      [&](const std::string&, const ptzstereo::stereo_frame_t& m) {
        status.countIn(ch, (wallUtime() - m.utime) / 1000.0);
        cv::Mat left, right;
        std::string error;
        if (!decodeImage(m.left, &left, &error) || !decodeImage(m.right, &right, &error)) {
          status.countDropped(ch, "bad_image");
          log.warn("bad_image",
                   "ptz-calibrate: dropped frame " + std::to_string(m.seq) + ": " + error);
          return;
        }
        const std::string name = "frame " + std::to_string(m.seq);
        const auto result = collector.offer(left, right, name);
        status.increment(std::string("frames_") + resultName(result));
        if (result != LiveCollector::Result::kKept) return;
        const size_t n = collector.views().size();
        if (!save_dir.empty()) {
          char index[16];
          std::snprintf(index, sizeof index, "%03zu.png", n);
          cv::imwrite(save_dir + "/left" + index, left);
          cv::imwrite(save_dir + "/right" + index, right);
        }
        std::printf("view %zu/%zu kept (%s): coverage %s\n", n, target, name.c_str(),
                    collector.progressText().c_str());
        std::fflush(stdout);
        if (n >= target) StopFlag::request();
      },
      1);
  std::printf("ptz-calibrate: listening on %s for the board %s; %zu views wanted (Ctrl-C ends)\n",
              ch.c_str(), boardOf(p).text().c_str(), target);
  serveUntilStopped(lcm, status);
  std::printf("%zu views kept; coverage %s\n", collector.views().size(),
              collector.progressText().c_str());
  calibrateAndWrite(p, collector.views(), collector.imageSize());
  return 0;
}

}  // namespace
}  // namespace ptz::perception

int main(int argc, char** argv) {
  ptz::Params p("ptz-calibrate",
                "Stereo calibration from chessboard views (image pairs, or STEREO_FRAME live): "
                "intrinsics (5-coefficient Brown), R, T, E, F, rectification, per-view errors; "
                "writes the rig file.");
  ptz::perception::declare(p);
  try {
    if (!p.parse(argc, argv)) return 0;
    // Image files need no network: only the live source opens LCM.
    if (p.getString("source") == "lcm")
      return ptz::runProcess(argc, argv, p, ptz::perception::runLive);
    if (p.getString("source") != "files") {
      throw ptz::ConfigError("flag --source: expected files or lcm, got '" + p.getString("source") +
                             "'");
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
