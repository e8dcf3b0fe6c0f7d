// The calibration's output files: the rig file with the report beside the rig's own fields, and
// ROS camera_info YAML.
#include <algorithm>
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

}  // namespace ptz::perception
