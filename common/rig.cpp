#include "common/rig.hpp"

#include <Eigen/Core>
#include <opencv2/core/eigen.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <tuple>

#include "common/config.hpp"

namespace ptz {

const char* sideName(Side side) {
  return side == Side::kLeft ? "left" : "right";
}

Eigen::Matrix3d rotationY(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix();
}
Eigen::Matrix3d rotationX(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix();
}

Eigen::Vector2d distortNormalised(const Eigen::Vector2d& xy, const std::array<double, 5>& d) {
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  return {x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x),
          y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y};
}

Eigen::Vector3d CameraView::toCamera(const Eigen::Vector3d& p_head) const {
  return rotation_head_camera.transpose() * (p_head - position_head_m);
}

Eigen::Vector2d CameraView::projectCamera(const Eigen::Vector3d& p) const {
  if (!(p.z() > 0)) return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  const Eigen::Vector2d xy =
      distortNormalised({p.x() / p.z(), p.y() / p.z()}, intrinsics.distortion);
  return {intrinsics.fx * xy.x() + intrinsics.cx, intrinsics.fy * xy.y() + intrinsics.cy};
}

Eigen::Vector2d CameraView::project(const Eigen::Vector3d& p_head) const {
  return projectCamera(toCamera(p_head));
}

Intrinsics CameraSpec::intrinsicsAt(double zoom) const {
  if (!std::isfinite(zoom) || zoom <= zoom_table.front().zoom) return zoom_table.front().intrinsics;
  if (zoom >= zoom_table.back().zoom) return zoom_table.back().intrinsics;
  auto hi = std::upper_bound(zoom_table.begin(), zoom_table.end(), zoom,
                             [](double z, const ZoomEntry& e) { return z < e.zoom; });
  auto lo = hi - 1;
  const double w = (zoom - lo->zoom) / (hi->zoom - lo->zoom);
  const Intrinsics& a = lo->intrinsics;
  const Intrinsics& b = hi->intrinsics;
  auto mix = [w](double u, double v) { return u + w * (v - u); };
  Intrinsics k{mix(a.fx, b.fx), mix(a.fy, b.fy), mix(a.cx, b.cx), mix(a.cy, b.cy), {}};
  for (int i = 0; i < 5; ++i) k.distortion[i] = mix(a.distortion[i], b.distortion[i]);
  return k;
}

void StereoRig::cameraPose(Side side, double pan_rad, double tilt_rad, Eigen::Matrix3d* R_out,
                           Eigen::Vector3d* c_out) const {
  // Home poses in the head frame: left axes = head axes; centres at -/+ half the baseline.
  const Eigen::Vector3d right_centre_in_left = -home.R.transpose() * home.T;
  const Eigen::Vector3d half = right_centre_in_left / 2;
  const Eigen::Matrix3d R_home =
      side == Side::kLeft ? Eigen::Matrix3d::Identity() : Eigen::Matrix3d(home.R.transpose());
  const Eigen::Vector3d c_home = side == Side::kLeft ? Eigen::Vector3d(-half) : half;
  const Eigen::Vector3d offset = camera(side).optical_centre_from_pivot_m;
  const Eigen::Vector3d pivot = c_home - R_home * offset;
  const Eigen::Matrix3d R = R_home * rotationY(pan_rad) * rotationX(tilt_rad);
  *R_out = R;
  *c_out = pivot + R * offset;
}

CameraView StereoRig::view(Side side, const PtzPose& pose) const {
  CameraView v;
  const CameraSpec& spec = camera(side);
  v.width = spec.width;
  v.height = spec.height;
  v.intrinsics = spec.intrinsicsAt(pose.zoom);
  cameraPose(side, pose.pan_rad, pose.tilt_rad, &v.rotation_head_camera, &v.position_head_m);
  return v;
}

StereoExtrinsics StereoRig::extrinsics(const PtzPose& lp, const PtzPose& rp) const {
  Eigen::Matrix3d Rl, Rr;
  Eigen::Vector3d cl, cr;
  cameraPose(Side::kLeft, lp.pan_rad, lp.tilt_rad, &Rl, &cl);
  cameraPose(Side::kRight, rp.pan_rad, rp.tilt_rad, &Rr, &cr);
  StereoExtrinsics e;
  e.R = Rr.transpose() * Rl;
  e.T = Rr.transpose() * (cl - cr);
  return e;
}

namespace {

// The largest image side a rig file may declare (a guard against absurd allocations).
constexpr int kMaxImageSide = 16384;

Intrinsics readIntrinsics(const cv::FileNode& node, const std::string& where) {
  cv::Mat K = readMatrix(node, "camera_matrix", 3, 3, where);
  cv::Mat D = readMatrix(node, "distortion_coefficients", 1, 5, where);
  Intrinsics k{K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2), {}};
  for (int i = 0; i < 5; ++i) k.distortion[i] = D.at<double>(i);
  if (k.fx <= 0 || k.fy <= 0)
    throw ConfigError(where + ": field 'camera_matrix' has fx or fy <= 0");
  return k;
}

CameraSpec readCamera(const cv::FileNode& root, const std::string& side, int width, int height,
                      const std::string& file_where) {
  const std::string where = file_where + ", " + side;
  cv::FileNode node = readNode(root, side, file_where);
  checkFields(node, {"zoom_table", "optical_centre_from_pivot_m"}, where);
  CameraSpec spec;
  spec.width = width;
  spec.height = height;
  cv::FileNode table = readNode(node, "zoom_table", where);
  if (!table.isSeq() || table.size() == 0) {
    throw ConfigError(where + ": field 'zoom_table' must be a non-empty list");
  }
  int i = 0;
  for (const auto& item : table) {
    const std::string item_where = where + ".zoom_table[" + std::to_string(i++) + "]";
    checkFields(item, {"zoom", "camera_matrix", "distortion_coefficients"}, item_where);
    ZoomEntry e;
    e.zoom = readDouble(item, "zoom", item_where, Range::above(0));
    e.intrinsics = readIntrinsics(item, item_where);
    if (!spec.zoom_table.empty() && e.zoom <= spec.zoom_table.back().zoom) {
      throw ConfigError(item_where + ": field 'zoom' must increase along the table");
    }
    spec.zoom_table.push_back(e);
  }
  auto offset = readNumbers(node, "optical_centre_from_pivot_m", 3, where);
  spec.optical_centre_from_pivot_m = {offset[0], offset[1], offset[2]};
  return spec;
}

void writeCamera(cv::FileStorage& fs, const CameraSpec& spec) {
  fs << "{";
  fs << "zoom_table"
     << "[";
  for (const auto& e : spec.zoom_table) {
    const Intrinsics& k = e.intrinsics;
    cv::Mat K = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
    cv::Mat D(1, 5, CV_64F);
    for (int i = 0; i < 5; ++i) D.at<double>(i) = k.distortion[i];
    fs << "{"
       << "zoom" << e.zoom << "camera_matrix" << K << "distortion_coefficients" << D << "}";
  }
  fs << "]";
  const auto& o = spec.optical_centre_from_pivot_m;
  fs << "optical_centre_from_pivot_m" << std::vector<double>{o.x(), o.y(), o.z()};
  fs << "}";
}

}  // namespace

const std::vector<std::string> StereoRig::kRigReportFields = {
    "E", "F", "R1", "R2", "P1", "P2", "Q", "calibration", "zoom_calibrations", "pivot_calibration"};

StereoRig StereoRig::load(const std::string& path) {
  cv::FileStorage fs = openForRead(path, "rig file");
  const std::string where = "rig file '" + path + "'";
  cv::FileNode root = fs.root();
  std::vector<std::string> known = {"image_width", "image_height", "left", "right", "R", "T"};
  known.insert(known.end(), kRigReportFields.begin(), kRigReportFields.end());
  checkFields(root, known, where);
  const int width = readInt(root, "image_width", where, Range::between(1, kMaxImageSide));
  const int height = readInt(root, "image_height", where, Range::between(1, kMaxImageSide));
  StereoRig rig;
  rig.left = readCamera(root, "left", width, height, where);
  rig.right = readCamera(root, "right", width, height, where);
  cv::Mat R = readMatrix(root, "R", 3, 3, where);
  cv::Mat T = readMatrix(root, "T", 3, 1, where);
  cv::cv2eigen(R, rig.home.R);
  cv::cv2eigen(T, rig.home.T);
  if ((rig.home.R * rig.home.R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
      rig.home.R.determinant() < 0) {
    throw ConfigError(where + ": field 'R' is not a rotation matrix");
  }
  if (rig.home.T.norm() <= 0) throw ConfigError(where + ": field 'T' is zero (no baseline)");
  return rig;
}

void StereoRig::save(const std::string& path,
                     const std::function<void(cv::FileStorage&)>& extra_fields) const {
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw ConfigError("rig file '" + path + "': cannot write");
  // Extra fields first: a file cut anywhere then lacks or breaks a rig field and load() refuses it.
  if (extra_fields) extra_fields(fs);
  fs << "image_width" << left.width << "image_height" << left.height;
  fs << "left";
  writeCamera(fs, left);
  fs << "right";
  writeCamera(fs, right);
  cv::Mat R, T;
  cv::eigen2cv(home.R, R);
  cv::eigen2cv(home.T, T);
  fs << "R" << R << "T" << T;
}

void declareRigParams(Params& params) {
  params.add("rig_file", "", "rig file (OpenCV YAML); empty: the built-in default rig");
  params.add("image_size", "",
             "the cameras read out at this size: vga, 720p, 1080p or WIDTHxHEIGHT (the field of "
             "view kept); empty: the rig file's size");
}

bool parseImageSize(const std::string& text, int* width_px, int* height_px, std::string* why) {
  static const std::map<std::string, std::pair<int, int>> named = {
      {"vga", {640, 480}}, {"720p", {1280, 720}}, {"1080p", {1920, 1080}}};
  if (const auto it = named.find(text); it != named.end()) {
    std::tie(*width_px, *height_px) = it->second;
    return true;
  }
  int w = 0, h = 0, end = 0;
  if (std::sscanf(text.c_str(), "%dx%d%n", &w, &h, &end) != 2 ||
      end != static_cast<int>(text.size())) {
    *why = "must be vga, 720p, 1080p or WIDTHxHEIGHT";
    return false;
  }
  if (w < 16 || h < 16 || w > 4096 || h > 4096) {
    *why = "each side must be 16 .. 4096 px";
    return false;
  }
  *width_px = w;
  *height_px = h;
  return true;
}

StereoRig rigFromParams(const Params& params) {
  const std::string path = params.getExistingPath("rig_file");
  const StereoRig rig = path.empty() ? StereoRig::makeDefault() : StereoRig::load(path);
  const std::string size = params.getString("image_size");
  if (size.empty()) return rig;
  int width_px = 0, height_px = 0;
  std::string why;
  if (!parseImageSize(size, &width_px, &height_px, &why)) throw params.invalid("image_size", why);
  return rig.atSize(width_px, height_px);
}

StereoRig StereoRig::makeDefault() {
  StereoRig rig;
  for (Side side : {Side::kLeft, Side::kRight}) {
    CameraSpec& spec = side == Side::kLeft ? rig.left : rig.right;
    const double cx_offset = side == Side::kLeft ? 1.5 : -2.0;
    for (double zoom : {1.0, 2.0, 4.0, 7.0, 10.0}) {
      Intrinsics k;
      k.fx = 500.0 * zoom;
      k.fy = 500.0 * zoom;
      k.cx = 319.5 + cx_offset;
      k.cy = 239.5 + 1.0;
      // Barrel distortion fades as the lens zooms in.
      k.distortion = {-0.12 / zoom, 0.04 / zoom, 0.0004, -0.0003, 0.0};
      spec.zoom_table.push_back({zoom, k});
    }
    // The optical centre sits in front of the tilt axis, as on most PTZ domes.
    spec.optical_centre_from_pivot_m = {0.0, 0.0, 0.04};
  }
  // 0.3 m baseline with a slight toe-in and roll, as a real rig is never aligned.
  rig.home.R = rotationY(-0.01) * rotationX(0.004) *
               Eigen::AngleAxisd(0.003, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  rig.home.T = rig.home.R * Eigen::Vector3d(-0.30, 0.002, 0.001);
  return rig;
}

StereoRig StereoRig::atSize(int width_px, int height_px) const {
  StereoRig rig = *this;
  for (CameraSpec* c : {&rig.left, &rig.right}) {
    const double s = static_cast<double>(width_px) / c->width;
    const double extra_rows_px = height_px - c->height * s;
    for (ZoomEntry& z : c->zoom_table) {
      z.intrinsics.fx *= s;
      z.intrinsics.fy *= s;
      z.intrinsics.cx = (z.intrinsics.cx + 0.5) * s - 0.5;
      z.intrinsics.cy = (z.intrinsics.cy + 0.5) * s - 0.5 + extra_rows_px / 2;
    }
    c->width = width_px;
    c->height = height_px;
  }
  return rig;
}

}  // namespace ptz
