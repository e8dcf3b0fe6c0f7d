// The stereo rig model: intrinsics as a function of zoom, Brown distortion, home extrinsics
// and the pan-tilt kinematics of each camera. Shared by the simulator, perception and control.
//
// Frames (DESIGN.md): camera frame x right, y down, z forward (OpenCV). Head frame: origin at
// the midpoint of the baseline, axes of the left camera at pan = tilt = 0.
// Pan turns the optical axis towards +x (a rotation about the camera's home y axis, fixed to
// the base); tilt turns it towards -y, up (about the x axis carried by the pan stage):
//   R_head_camera(pan, tilt) = R_head_camera(home) * Ry(pan) * Rx(tilt).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace cv {
class FileStorage;
}

namespace ptz {

// VGA-equivalent pixels: an image's pixels times kVgaWidthPx / its width. atSize keeps the field of
// view, so centring errors and target sizes in these units compare across image sizes.
constexpr double kVgaWidthPx = 640;
inline double vgaPxPerPx(int width_px) {
  return kVgaWidthPx / (width_px > 0 ? width_px : 1);
}

enum class Side { kLeft = 0, kRight = 1 };
const char* sideName(Side side);

// Pinhole intrinsics (pixels) and Brown distortion k1, k2, p1, p2, k3 (OpenCV's order).
struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> distortion{};
};

struct ZoomEntry {
  double zoom = 1;  // zoom ratio (1 = widest)
  Intrinsics intrinsics;
};

struct PtzPose {
  double pan_rad = 0;
  double tilt_rad = 0;
  double zoom = 1;
};

// Applies Brown distortion to normalised image coordinates (x/z, y/z).
Eigen::Vector2d distortNormalised(const Eigen::Vector2d& xy, const std::array<double, 5>& d);

// One camera at one pan/tilt/zoom: its current projection.
struct CameraView {
  int width = 0, height = 0;
  Intrinsics intrinsics;
  Eigen::Matrix3d rotation_head_camera = Eigen::Matrix3d::Identity();
  Eigen::Vector3d position_head_m = Eigen::Vector3d::Zero();

  Eigen::Vector3d toCamera(const Eigen::Vector3d& p_head) const;
  // Pixel of a head-frame point, with distortion. Points behind the camera give NaN.
  Eigen::Vector2d project(const Eigen::Vector3d& p_head) const;
  // Pixel of a camera-frame point, with distortion.
  Eigen::Vector2d projectCamera(const Eigen::Vector3d& p_camera) const;
};

struct CameraSpec {
  int width = 640, height = 480;
  // Sorted by zoom, at least one entry; intrinsics are interpolated linearly in zoom.
  std::vector<ZoomEntry> zoom_table;
  // Optical centre relative to the pan/tilt pivot, in the camera frame, m.
  Eigen::Vector3d optical_centre_from_pivot_m = Eigen::Vector3d::Zero();

  Intrinsics intrinsicsAt(double zoom) const;
  double minZoom() const { return zoom_table.front().zoom; }
  double maxZoom() const { return zoom_table.back().zoom; }
};

// Relative pose of the right camera: x_right = R x_left + T (OpenCV's stereoCalibrate).
struct StereoExtrinsics {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d T = Eigen::Vector3d::Zero();
};

class StereoRig {
 public:
  CameraSpec left, right;
  StereoExtrinsics home;  // extrinsics at pan = tilt = 0 of both cameras

  const CameraSpec& camera(Side side) const { return side == Side::kLeft ? left : right; }
  // Pose of a camera in the head frame at the given pan and tilt.
  void cameraPose(Side side, double pan_rad, double tilt_rad, Eigen::Matrix3d* rotation_head_camera,
                  Eigen::Vector3d* position_head_m) const;
  CameraView view(Side side, const PtzPose& pose) const;
  StereoExtrinsics extrinsics(const PtzPose& left_pose, const PtzPose& right_pose) const;
  double baselineM() const { return home.T.norm(); }

  // OpenCV FileStorage YAML; load() throws ConfigError naming the file, the field and the value,
  // and refuses fields it does not know (but for a calibration's report beside the rig's).
  static StereoRig load(const std::string& path);
  // Top-level fields load() accepts beside the rig's own and does not read: ptz-calibrate's
  // report (perception/calibrate/README.md). Any other field is refused.
  static const std::vector<std::string> kRigReportFields;
  // extra_fields writes more top-level fields (ptz-calibrate's report) before the rig's own.
  void save(const std::string& path,
            const std::function<void(cv::FileStorage&)>& extra_fields = {}) const;
  // A plausible PTZ rig: VGA, 1x-10x zoom, 0.3 m baseline, mild distortion.
  static StereoRig makeDefault();
  // The same cameras read out at another image size, as a camera's own scaler does: the
  // horizontal field of view kept, pixel centres mapped (x + 0.5) * s - 0.5, another aspect
  // ratio cropped or extended about the principal point's row. Distortion (normalised) is kept.
  StereoRig atSize(int width_px, int height_px) const;
};

class Params;
// Declares rig_file and image_size, the parameters rigFromParams reads.
void declareRigParams(Params& params);
// The rig of the parameter rig_file (the built-in default rig when empty), read out at
// image_size when that is set ("vga", "720p", "1080p" or WIDTHxHEIGHT; empty: the file's size).
StereoRig rigFromParams(const Params& params);
// "vga" 640x480, "720p" 1280x720, "1080p" 1920x1080, or "WIDTHxHEIGHT" (16..4096 each); false
// with the reason otherwise.
bool parseImageSize(const std::string& text, int* width_px, int* height_px, std::string* why);

Eigen::Matrix3d rotationY(double angle_rad);
Eigen::Matrix3d rotationX(double angle_rad);

}  // namespace ptz
