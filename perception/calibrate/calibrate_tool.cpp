#include "perception/calibrate/calibrate_tool.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "perception/calibrate/calibration_files.hpp"
#include "perception/calibrate/calibration_steps.hpp"

namespace ptz::perception {

void declareCalibrateParams(Params& p) {
  p.add("mode", "stereo",
        "stereo: the home calibration; zoom: add the intrinsics at --zoom to rig_file's zoom "
        "table; pivot: the optical centre's offset from the pan/tilt pivot into rig_file");
  p.add("rig_file", "", "zoom, pivot: the rig file to extend (written to --output)");
  p.add("source", "files", "files (images_dir or image_list) or lcm (STEREO_FRAME, live)");
  p.add("images_dir", "",
        "folder of image pairs <left_prefix>X / <right_prefix>X (pivot: one folder per board "
        "station, separated by commas)");
  p.add("left_prefix", "left", "file-name prefix of the left images in images_dir");
  p.add("right_prefix", "right", "file-name prefix of the right images in images_dir");
  p.add("image_list", "",
        "text file of 'left_path right_path [left_pan_deg left_tilt_deg right_pan_deg "
        "right_tilt_deg]' lines (instead of images_dir; pivot: the angles refine the estimate, "
        "one list per board station, separated by commas)");
  p.add("board_cols", 9, "", "inner corners along a board row (squares - 1)",
        Range::between(2, 1000));
  p.add("board_rows", 6, "", "inner corners along a board column (squares - 1)",
        Range::between(2, 1000));
  p.add("square_m", 0.025, "m", "side of a board square", Range::above(0));
  p.add("output", "rig_calibrated.yaml", "rig file to write (StereoRig + calibration report)");
  p.add("camera_info_dir", "",
        "also write ROS camera_info here (created if missing): left.yaml/right.yaml at zoom 1, "
        "left_zoomZ.yaml/right_zoomZ.yaml at every other zoom of the rig; empty: no");
  p.add("zoom", 1.0, "", "zoom position of both cameras in the images (their zoom table entry)",
        Range::above(0));
  p.add("min_views", 8, "", "fewest views with the board in both images", Range::atLeast(1));
  p.add("max_view_error_px", 1.0, "px", "per-view RMS above which a view is an outlier",
        Range::above(0));
  p.add("drop_outliers", false, "recalibrate without the outlier views (else only report them)");
  p.add("min_tilt_deg", 10.0, "deg", "some view must tilt the board at least this much",
        Range::between(0, 90));
  p.add("refine_intrinsics", true,
        "refine the intrinsics jointly with R, T in the stereo fit (false: keep the mono ones)");
  p.add("rectify_alpha", 0.0, "",
        "stereoRectify alpha: 0 valid pixels only, 1 all pixels (-1: OpenCV's default)",
        Range::between(-1, 1));
  p.add("target_views", 20, "", "lcm: stop after keeping this many views (or on SIGINT)",
        Range::between(1, 10000));
  p.add("min_coverage_distance", 0.2, "",
        "lcm: L1 distance in (x, y, size, skew) a view needs from every kept one",
        Range::atLeast(0));
  p.add("home_tolerance_rad", 0.002, "rad",
        "lcm: frames whose pan or tilt is further from 0 are not used", Range::atLeast(0));
  p.add("save_views_dir", "", "lcm: also write the kept views as leftNNN.png/rightNNN.png here");
}

BoardSpec boardOf(const Params& p) {
  return {p.getInt("board_cols"), p.getInt("board_rows"), p.getDouble("square_m")};  // ranged
}

namespace {

// Progress lines on stderr, one sink for the run: every stage line, per-image lines at most 4 a
// second (the last of a run of them is printed before the next stage or at an empty stage line).
const Progress& stderrProgress() {
  struct State {
    std::chrono::steady_clock::time_point last_printed{};
    std::string pending;
  };
  static const Progress progress = [state = std::make_shared<State>()](const std::string& line,
                                                                       bool stage) {
    const auto now = std::chrono::steady_clock::now();
    if (!stage && now - state->last_printed < std::chrono::milliseconds(250)) {
      state->pending = line;
      return;
    }
    if (stage && !state->pending.empty()) {
      std::fprintf(stderr, "ptz-calibrate: %s\n", state->pending.c_str());
    }
    state->pending.clear();
    if (!line.empty()) std::fprintf(stderr, "ptz-calibrate: %s\n", line.c_str());
    state->last_printed = now;
  };
  return progress;
}

StereoOptions optionsOf(const Params& p) {
  StereoOptions o;
  o.min_views = p.getInt("min_views");
  o.max_view_error_px = p.getDouble("max_view_error_px");
  o.drop_outliers = p.getBool("drop_outliers");
  o.min_tilt_deg = p.getDouble("min_tilt_deg");
  o.rectify_alpha = p.getDouble("rectify_alpha");
  o.refine_intrinsics = p.getBool("refine_intrinsics");
  o.progress = stderrProgress();
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

// camera_info for every zoom of the rig file just written.
void writeCameraInfos(const Params& p) {
  const std::string info_dir = p.getString("camera_info_dir");
  if (info_dir.empty()) return;
  const StereoRig rig = StereoRig::load(p.getString("output"));
  for (const auto& path : saveCameraInfos(info_dir, rig, p.getDouble("rectify_alpha"))) {
    std::printf("wrote %s\n", path.c_str());
  }
}

}  // namespace

void checkOutputs(const Params& p) {
  if (!p.getString("camera_info_dir").empty()) {
    requireWritableDir(p.getString("camera_info_dir"), "camera_info_dir");
  }
}

void calibrateAndWrite(const Params& p, const std::vector<ViewPair>& views, cv::Size size) {
  const StereoCalibration c = calibrateStereo(views, boardOf(p), size, optionsOf(p));
  printReport(c);
  saveCalibration(p.getString("output"), c.toRig(p.getDouble("zoom")), c);
  std::printf("wrote %s\n", p.getString("output").c_str());
  writeCameraInfos(p);
}

namespace {

// Pairs from an image list (list = true) or a folder.
DetectedViews detectFiles(const Params& p, const std::string& source, bool list) {
  const BoardSpec board = boardOf(p);
  if (source.empty()) {
    throw ConfigError("give --images-dir FOLDER or --image-list FILE (see ptz-calibrate --help)");
  }
  const std::vector<ImagePair> pairs =
      list ? pairsFromList(source)
           : pairsFromFolder(source, p.getString("left_prefix"), p.getString("right_prefix"));
  DetectedViews detected = detectPairs(pairs, board, stderrProgress());
  stderrProgress()("", true);  // the last image's line
  for (const auto& s : detected.skipped) std::printf("skipped: %s\n", s.c_str());
  std::printf("board %s found in both images of %zu of %zu pairs\n", board.text().c_str(),
              detected.views.size(), pairs.size());
  return detected;
}

std::string rigFileToExtend(const Params& p) {
  if (p.getString("rig_file").empty()) {
    throw ConfigError("--mode " + p.getString("mode") + " needs --rig-file (the home calibration)");
  }
  return p.getExistingPath("rig_file");
}

void printZoom(double zoom, Side side, const MonoCalibration& m) {
  std::printf("%s at zoom %g: fx %.2f fy %.2f cx %.2f cy %.2f px, RMS %.3f px, %zu views\n",
              sideName(side), zoom, m.K.at<double>(0, 0), m.K.at<double>(1, 1),
              m.K.at<double>(0, 2), m.K.at<double>(1, 2), m.rms_px, m.view_rms_px.size());
}

void printPivot(Side side, const PivotEstimate& e, int views) {
  const Eigen::Vector3d& o = e.optical_centre_from_pivot_m;
  std::printf("%s: optical centre from pivot [%.4f, %.4f, %.4f] m from %d views; ", sideName(side),
              o.x(), o.y(), o.z(), views);
  if (std::isfinite(e.reprojection_rms_px)) {
    std::printf("refined with the pan/tilt angles: reprojection %.3f px\n", e.reprojection_rms_px);
  } else {
    std::printf("no pan/tilt angles (an image list gives them): linear fit, residual %.4f m\n",
                e.residual_rms_m);
  }
}

}  // namespace

int runFiles(const Params& p) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string mode = p.getString("mode");
  if (mode != "stereo" && mode != "zoom" && mode != "pivot") {
    throw p.invalid("mode", "must be stereo, zoom or pivot");
  }
  if (mode != "stereo") rigFileToExtend(p);  // before the slow part
  checkOutputs(p);
  const bool list = !p.getString("image_list").empty();
  const std::string source = list ? p.getString("image_list") : p.getString("images_dir");
  if (mode == "pivot") {  // one board station per folder or list
    std::vector<DetectedViews> stations;
    std::stringstream sources(source);
    for (std::string one; std::getline(sources, one, ',');) {
      stations.push_back(detectFiles(p, one, list));
    }
    if (stations.empty()) stations.push_back(detectFiles(p, "", list));
    const PivotStep step = setPivotOffsets(rigFileToExtend(p), p.getString("output"),
                                           p.getDouble("zoom"), stations, boardOf(p));
    printPivot(Side::kLeft, step.left, step.left_views);
    printPivot(Side::kRight, step.right, step.right_views);
  } else {
    const DetectedViews detected = detectFiles(p, source, list);
    if (mode == "stereo") calibrateAndWrite(p, detected.views, detected.image_size);
    if (mode == "zoom") {
      const double zoom = p.getDouble("zoom");
      const ZoomStep step = addZoomEntry(rigFileToExtend(p), p.getString("output"), zoom, detected,
                                         boardOf(p), p.getInt("min_views"));
      printZoom(zoom, Side::kLeft, step.left);
      printZoom(zoom, Side::kRight, step.right);
    }
  }
  if (mode != "stereo") {
    std::printf("wrote %s\n", p.getString("output").c_str());
    writeCameraInfos(p);
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%.2f s\n", s);
  return 0;
}

LiveViews::LiveViews(const Params& p)
    : collector_(boardOf(p), p.getDouble("min_coverage_distance")),
      target_(static_cast<size_t>(std::max(1, p.getInt("target_views")))),
      save_dir_(p.getString("save_views_dir")),
      zoom_(p.getDouble("zoom")),
      home_tolerance_rad_(p.getDouble("home_tolerance_rad")) {}

std::string LiveViews::notAtHome(const ptzstereo::stereo_frame_t& m) const {
  // The stereo calibration holds at home and at one zoom: a view taken elsewhere would mix in
  // the kinematics.
  const double t = home_tolerance_rad_;
  if (std::abs(m.left.pan_rad) > t || std::abs(m.left.tilt_rad) > t ||
      std::abs(m.right.pan_rad) > t || std::abs(m.right.tilt_rad) > t ||
      std::abs(m.left.zoom - zoom_) > 1e-3 || std::abs(m.right.zoom - zoom_) > 1e-3) {
    return "cameras not at pan = tilt = 0 and zoom " + std::to_string(zoom_) +
           " (home_tolerance_rad, --zoom)";
  }
  return "";
}

LiveCollector::Result LiveViews::offer(const cv::Mat& left, const cv::Mat& right, int64_t seq) {
  const std::string name = "frame " + std::to_string(seq);
  const auto result = collector_.offer(left, right, name);
  if (result != LiveCollector::Result::kKept) return result;
  const size_t n = collector_.views().size();
  if (!save_dir_.empty()) {
    char index[16];
    std::snprintf(index, sizeof index, "%03zu.png", n);
    cv::imwrite(save_dir_ + "/left" + index, left);
    cv::imwrite(save_dir_ + "/right" + index, right);
  }
  std::printf("view %zu/%zu kept (%s): coverage %s\n", n, target_, name.c_str(),
              collector_.progressText().c_str());
  std::fflush(stdout);
  return result;
}

}  // namespace ptz::perception
