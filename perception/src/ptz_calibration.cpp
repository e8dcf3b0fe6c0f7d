#include "perception/ptz_calibration.hpp"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <sstream>

namespace ptz::perception {

MonoCalibration calibrateAtZoom(const ZoomViews& z, const BoardSpec& board, cv::Size image_size,
                                bool zoomed_in, int min_views) {
  std::ostringstream what;
  what << "zoom " << z.zoom;
  if (static_cast<int>(z.corners_px.size()) < min_views) {
    throw CalibrationError(what.str() + ": too few views: " + std::to_string(z.corners_px.size()) +
                           ", need at least " + std::to_string(min_views));
  }
  const std::vector<std::vector<cv::Point3f>> object(z.corners_px.size(), boardPoints(board));
  return calibrateMono(object, z.corners_px, image_size, zoomed_in ? cv::CALIB_FIX_K3 : 0,
                       what.str());
}

std::vector<ZoomEntry> calibrateZoomTable(const std::vector<ZoomViews>& zooms,
                                          const BoardSpec& board, cv::Size image_size,
                                          int min_views) {
  double widest = 1e300;
  for (const ZoomViews& z : zooms) widest = std::min(widest, z.zoom);
  CameraSpec camera;
  for (const ZoomViews& z : zooms) {
    const MonoCalibration m = calibrateAtZoom(z, board, image_size, z.zoom > widest, min_views);
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
