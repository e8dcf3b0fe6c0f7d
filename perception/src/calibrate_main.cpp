// ptz-calibrate: stereo calibration from chessboard views into the rig file every process loads.
// Source: left/right image files (a folder or a list). Exit 2 with the files named on bad input.
#include <chrono>
#include <cstdio>

#include "perception/calibration.hpp"
#include "perception/calibration_files.hpp"

namespace ptz::perception {
namespace {

void declare(Params& p) {
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
}

std::vector<ImagePair> pairsOf(const Params& p) {
  if (!p.getString("image_list").empty()) return pairsFromList(p.getString("image_list"));
  if (p.getString("images_dir").empty()) {
    throw ConfigError("give --images-dir FOLDER or --image-list FILE (see ptz-calibrate --help)");
  }
  return pairsFromFolder(p.getString("images_dir"), p.getString("left_prefix"),
                         p.getString("right_prefix"));
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

int run(const Params& p) {
  const auto t0 = std::chrono::steady_clock::now();
  BoardSpec board{p.getInt("board_cols"), p.getInt("board_rows"), p.getDouble("square_m")};
  if (board.inner_cols < 2 || board.inner_rows < 2 || board.square_m <= 0) {
    throw ConfigError("--board-cols and --board-rows must be >= 2 and --square-m > 0");
  }
  StereoOptions options;
  options.min_views = p.getInt("min_views");
  options.max_view_error_px = p.getDouble("max_view_error_px");
  options.drop_outliers = p.getBool("drop_outliers");
  options.min_tilt_deg = p.getDouble("min_tilt_deg");
  options.rectify_alpha = p.getDouble("rectify_alpha");
  options.refine_intrinsics = p.getBool("refine_intrinsics");
  const std::vector<ImagePair> pairs = pairsOf(p);
  const DetectedViews detected = detectPairs(pairs, board);
  for (const auto& s : detected.skipped) std::printf("skipped: %s\n", s.c_str());
  std::printf("board %s found in both images of %zu of %zu pairs\n", board.text().c_str(),
              detected.views.size(), pairs.size());
  const StereoCalibration c = calibrateStereo(detected.views, board, detected.image_size, options);
  printReport(c);
  saveCalibration(p.getString("output"), c.toRig(p.getDouble("zoom")), c);
  std::printf("wrote %s", p.getString("output").c_str());
  const std::string info_dir = p.getString("camera_info_dir");
  if (!info_dir.empty()) {
    saveCameraInfo(info_dir + "/left.yaml", c, Side::kLeft);
    saveCameraInfo(info_dir + "/right.yaml", c, Side::kRight);
    std::printf(", %s/left.yaml, %s/right.yaml", info_dir.c_str(), info_dir.c_str());
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf(" (%.2f s)\n", s);
  return 0;
}

}  // namespace
}  // namespace ptz::perception

int main(int argc, char** argv) {
  ptz::Params p("ptz-calibrate",
                "Stereo calibration from chessboard image pairs: intrinsics (5-coefficient Brown), "
                "R, T, E, F, rectification, per-view errors; writes the rig file.");
  ptz::perception::declare(p);
  try {
    if (!p.parse(argc, argv)) return 0;
    return ptz::perception::run(p);
  } catch (const ptz::ConfigError& e) {
    std::fprintf(stderr, "ptz-calibrate: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptz-calibrate: stopped: %s\n", e.what());
    return 3;
  }
}
