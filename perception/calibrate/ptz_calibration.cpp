#include "perception/calibrate/ptz_calibration.hpp"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <sstream>

namespace ptz::perception {

MonoCalibration calibrateAtZoom(const ZoomViews& z, const BoardSpec& board, cv::Size image_size,
                                const Intrinsics* widest, int min_views) {
  std::ostringstream what;
  what << "zoom " << z.zoom;
  if (static_cast<int>(z.corners_px.size()) < min_views) {
    throw CalibrationError(what.str() + ": too few views: " + std::to_string(z.corners_px.size()) +
                           ", need at least " + std::to_string(min_views));
  }
  const std::vector<std::vector<cv::Point3f>> object(z.corners_px.size(), boardPoints(board));
  if (!widest) return calibrateMono(object, z.corners_px, image_size, 0, what.str());
  // Zoomed in, the narrow field of view leaves k3 and the principal point poorly determined:
  // k3 = 0, and c held at the widest zoom's (refined from a first fit with c free).
  const MonoCalibration free =
      calibrateMono(object, z.corners_px, image_size, cv::CALIB_FIX_K3, what.str());
  cv::Mat K = free.K.clone();
  K.at<double>(0, 2) = widest->cx;
  K.at<double>(1, 2) = widest->cy;
  return calibrateMono(
      object, z.corners_px, image_size,
      cv::CALIB_USE_INTRINSIC_GUESS | cv::CALIB_FIX_PRINCIPAL_POINT | cv::CALIB_FIX_K3, what.str(),
      K, free.D);
}

std::vector<ZoomEntry> calibrateZoomTable(const std::vector<ZoomViews>& zooms,
                                          const BoardSpec& board, cv::Size image_size,
                                          int min_views) {
  std::vector<ZoomViews> sorted = zooms;
  std::sort(sorted.begin(), sorted.end(),
            [](const ZoomViews& a, const ZoomViews& b) { return a.zoom < b.zoom; });
  CameraSpec camera;
  for (const ZoomViews& z : sorted) {
    const Intrinsics* widest =
        camera.zoom_table.empty() ? nullptr : &camera.zoom_table[0].intrinsics;
    const MonoCalibration m = calibrateAtZoom(z, board, image_size, widest, min_views);
    setZoomEntry(&camera, {z.zoom, m.intrinsics()});
  }
  return camera.zoom_table;
}

void setZoomEntry(CameraSpec* camera, const ZoomEntry& entry) {
  auto& table = camera->zoom_table;
  auto it = std::lower_bound(table.begin(), table.end(), entry.zoom,
                             [](const ZoomEntry& e, double zoom) { return e.zoom < zoom; });
  if (it != table.end() && it->zoom == entry.zoom) {
    *it = entry;
  } else {
    table.insert(it, entry);
  }
}

}  // namespace ptz::perception
