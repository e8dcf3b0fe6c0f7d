#include "perception/calibrate/calibration_steps.hpp"

namespace ptz::perception {

StereoRig loadRigFor(const std::string& rig_path, cv::Size image_size) {
  StereoRig rig = StereoRig::load(rig_path);
  if (rig.left.width != image_size.width || rig.left.height != image_size.height) {
    throw CalibrationError("rig file '" + rig_path + "' is for " + std::to_string(rig.left.width) +
                           "x" + std::to_string(rig.left.height) + " images, these are " +
                           std::to_string(image_size.width) + "x" +
                           std::to_string(image_size.height));
  }
  return rig;
}

ZoomStep addZoomEntry(const std::string& rig_path, const std::string& output_path, double zoom,
                      const DetectedViews& d, const BoardSpec& board, int min_views) {
  StereoRig rig = loadRigFor(rig_path, d.image_size);
  ZoomStep step;
  for (Side side : {Side::kLeft, Side::kRight}) {
    CameraSpec& camera = side == Side::kLeft ? rig.left : rig.right;
    const ZoomViews views{zoom, side == Side::kLeft ? d.left_px : d.right_px};
    const Intrinsics widest = camera.zoom_table.front().intrinsics;
    MonoCalibration& m = side == Side::kLeft ? step.left : step.right;
    m = calibrateAtZoom(views, board, d.image_size, zoom > camera.minZoom() ? &widest : nullptr,
                        min_views);
    setZoomEntry(&camera, {zoom, m.intrinsics()});
  }
  // Read before writing: the output may be the rig file itself.
  const cv::FileStorage previous = openForRead(rig_path, "rig file");
  rig.save(output_path, [&](cv::FileStorage& fs) {
    copyReportFields(previous.root(), fs, {"zoom_calibrations"});
    fs << "zoom_calibrations"
       << "[";
    for (const auto& entry : previous["zoom_calibrations"]) {
      if (static_cast<double>(entry["zoom"]) != zoom) copyFileNode(fs, "", entry);
    }
    fs << "{"
       << "zoom" << zoom << "date_utc" << utcNow() << "rms_left_px" << step.left.rms_px
       << "rms_right_px" << step.right.rms_px << "views_left" << static_cast<int>(d.left_px.size())
       << "views_right" << static_cast<int>(d.right_px.size()) << "}";
    fs << "]";
  });
  return step;
}

PivotStep setPivotOffsets(const std::string& rig_path, const std::string& output_path, double zoom,
                          const std::vector<DetectedViews>& stations, const BoardSpec& board) {
  if (stations.empty()) throw CalibrationError("pan/tilt kinematics: no views");
  StereoRig rig = loadRigFor(rig_path, stations.front().image_size);
  PivotStep step;
  for (Side side : {Side::kLeft, Side::kRight}) {
    const bool left = side == Side::kLeft;
    std::vector<PivotView> views;
    for (size_t station = 0; station < stations.size(); ++station) {
      const DetectedViews& d = stations[station];
      const auto& corners = left ? d.left_px : d.right_px;
      const auto& angles = left ? d.left_pan_tilt_rad : d.right_pan_tilt_rad;
      for (size_t i = 0; i < corners.size(); ++i) {
        views.push_back({static_cast<int>(station), corners[i], angles[i][0], angles[i][1]});
      }
    }
    CameraSpec& camera = left ? rig.left : rig.right;
    PivotEstimate& e = left ? step.left : step.right;
    e = estimateOpticalCentreFromPivot(views, board, camera.intrinsicsAt(zoom));
    camera.optical_centre_from_pivot_m = e.optical_centre_from_pivot_m;
    (left ? step.left_views : step.right_views) = static_cast<int>(views.size());
  }
  const cv::FileStorage previous = openForRead(rig_path, "rig file");
  rig.save(output_path, [&](cv::FileStorage& fs) {
    copyReportFields(previous.root(), fs, {"pivot_calibration"});
    fs << "pivot_calibration"
       << "{"
       << "date_utc" << utcNow() << "residual_left_m" << step.left.residual_rms_m
       << "residual_right_m" << step.right.residual_rms_m << "reprojection_left_px"
       << step.left.reprojection_rms_px << "reprojection_right_px" << step.right.reprojection_rms_px
       << "stations" << static_cast<int>(stations.size()) << "views_left" << step.left_views
       << "views_right" << step.right_views << "}";
  });
  return step;
}

}  // namespace ptz::perception
