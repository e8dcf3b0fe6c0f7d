// The calibration's output files: the rig file with the report beside the rig's own fields, and
// ROS camera_info YAML.
#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include "perception/calibrate/calibration.hpp"

namespace ptz::perception {

void saveCalibration(const std::string& path, const StereoRig& rig, const StereoCalibration& c) {
  rig.save(path, [&c](cv::FileStorage& fs) {
    fs << "E" << c.E << "F" << c.F << "R1" << c.R1 << "R2" << c.R2 << "P1" << c.P1 << "P2" << c.P2
       << "Q" << c.Q;
    fs << "calibration"
       << "{";
    fs << "date_utc" << c.date_utc;
    fs << "board"
       << "{"
       << "inner_cols" << c.board.inner_cols << "inner_rows" << c.board.inner_rows << "square_m"
       << c.board.square_m << "}";
    // Mono RMS: each camera alone, before the stereo fit refines the intrinsics.
    fs << "mono_rms_left_px" << c.left.rms_px << "mono_rms_right_px" << c.right.rms_px
       << "rms_stereo_px" << c.stereo_rms_px << "mean_rectified_epipolar_px"
       << c.rectified_epipolar_px;
    fs << "views"
       << "[";
    for (size_t i = 0; i < c.views.size(); ++i) {
      const ViewReport& v = c.views[i];
      fs << "{"
         << "left" << v.left_name << "right" << v.right_name << "left_rms_px" << v.left_rms_px
         << "right_rms_px" << v.right_rms_px << "left_mono_rms_px" << c.left.view_rms_px[i]
         << "right_mono_rms_px" << c.right.view_rms_px[i] << "board_tilt_deg" << v.left_tilt_deg
         << "}";
    }
    fs << "]";
    fs << "dropped_views"
       << "[";
    for (const auto& d : c.dropped) {
      fs << "{"
         << "view" << d.name << "reason" << d.reason << "}";
    }
    fs << "]";
    fs << "}";
  });
}

void copyFileNode(cv::FileStorage& fs, const std::string& name, const cv::FileNode& node) {
  if (!name.empty()) fs << name;
  if (node.isMap() && !node["dt"].empty() && !node["rows"].empty()) {
    cv::Mat m;
    node >> m;
    fs << m;
  } else if (node.isMap()) {
    fs << "{";
    for (const auto& child : node) copyFileNode(fs, child.name(), child);
    fs << "}";
  } else if (node.isSeq()) {
    fs << "[";
    for (const auto& item : node) copyFileNode(fs, "", item);
    fs << "]";
  } else if (node.isInt()) {
    fs << static_cast<int>(node);
  } else if (node.isReal()) {
    fs << static_cast<double>(node);
  } else {
    fs << static_cast<std::string>(node);
  }
}

namespace {

void writeMatrix(std::ofstream& out, const char* name, const cv::Mat& m) {
  out << name << ":\n  rows: " << m.rows << "\n  cols: " << m.cols << "\n  data: [";
  for (int i = 0; i < m.rows * m.cols; ++i) {
    out << (i ? ", " : "") << std::setprecision(12) << m.at<double>(i / m.cols, i % m.cols);
  }
  out << "]\n";
}

}  // namespace

void copyReportFields(const cv::FileNode& rig_root, cv::FileStorage& fs,
                      const std::vector<std::string>& skip) {
  for (const auto& node : rig_root) {
    const std::string name = node.name();
    const bool rig_field = name == "image_width" || name == "image_height" || name == "left" ||
                           name == "right" || name == "R" || name == "T";
    if (!rig_field && std::find(skip.begin(), skip.end(), name) == skip.end()) {
      copyFileNode(fs, name, node);
    }
  }
}

void saveCameraInfo(const std::string& path, const StereoCalibration& c, Side side) {
  // Plain YAML: FileStorage's "%YAML:1.0" header is not valid YAML for ROS's parsers.
  std::ofstream out(path);
  if (!out) throw ConfigError("camera_info file '" + path + "': cannot write");
  const MonoCalibration& m = side == Side::kLeft ? c.left : c.right;
  out << "image_width: " << c.image_size.width << "\nimage_height: " << c.image_size.height
      << "\ncamera_name: " << sideName(side) << "\n";
  writeMatrix(out, "camera_matrix", m.K);
  out << "distortion_model: plumb_bob\n";
  writeMatrix(out, "distortion_coefficients", m.D);
  writeMatrix(out, "rectification_matrix", side == Side::kLeft ? c.R1 : c.R2);
  writeMatrix(out, "projection_matrix", side == Side::kLeft ? c.P1 : c.P2);
  if (!out) throw ConfigError("camera_info file '" + path + "': write failed");
}

namespace {

cv::Mat cameraMatrix(const Intrinsics& in) {
  return (cv::Mat_<double>(3, 3) << in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1);
}

}  // namespace

std::vector<std::string> saveCameraInfos(const std::string& dir, const StereoRig& rig,
                                         double rectify_alpha) {
  std::vector<double> zooms;
  for (const CameraSpec* camera : {&rig.left, &rig.right}) {
    for (const auto& entry : camera->zoom_table) zooms.push_back(entry.zoom);
  }
  std::sort(zooms.begin(), zooms.end());
  zooms.erase(std::unique(zooms.begin(), zooms.end()), zooms.end());
  std::vector<std::string> written;
  for (const double zoom : zooms) {
    // Both cameras at this zoom (a zoom only one table has: the other's interpolated).
    StereoCalibration c;
    c.image_size = {rig.left.width, rig.left.height};
    const Intrinsics left = rig.left.intrinsicsAt(zoom), right = rig.right.intrinsicsAt(zoom);
    c.left.K = cameraMatrix(left);
    c.right.K = cameraMatrix(right);
    c.left.D = cv::Mat(1, 5, CV_64F, const_cast<double*>(left.distortion.data())).clone();
    c.right.D = cv::Mat(1, 5, CV_64F, const_cast<double*>(right.distortion.data())).clone();
    cv::Mat R(3, 3, CV_64F), T(3, 1, CV_64F);
    for (int r = 0; r < 3; ++r) {
      T.at<double>(r) = rig.home.T(r);
      for (int k = 0; k < 3; ++k) R.at<double>(r, k) = rig.home.R(r, k);
    }
    cv::stereoRectify(c.left.K, c.left.D, c.right.K, c.right.D, c.image_size, R, T, c.R1, c.R2,
                      c.P1, c.P2, c.Q, cv::CALIB_ZERO_DISPARITY, rectify_alpha);
    char suffix[64] = "";
    if (zoom != 1.0) std::snprintf(suffix, sizeof suffix, "_zoom%g", zoom);
    for (const Side side : {Side::kLeft, Side::kRight}) {
      const std::string path = dir + "/" + sideName(side) + suffix + ".yaml";
      saveCameraInfo(path, c, side);
      written.push_back(path);
    }
  }
  return written;
}

void requireWritableDir(const std::string& dir, const std::string& what) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw ConfigError(what + " '" + dir + "': cannot create it: " + ec.message());
  if (!std::filesystem::is_directory(dir, ec)) {
    throw ConfigError(what + " '" + dir + "': not a folder");
  }
  const std::string probe = dir + "/.ptz-calibrate-write-test";
  {
    std::ofstream out(probe);
    if (!out) {
      throw ConfigError(what + " '" + dir + "': cannot write in it: " + std::strerror(errno));
    }
  }
  std::filesystem::remove(probe, ec);
}

}  // namespace ptz::perception
