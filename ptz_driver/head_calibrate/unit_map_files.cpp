#include "ptz_driver/head_calibrate/unit_map_files.hpp"

#include <opencv2/core/persistence.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

#include "common/config.hpp"
#include "ptz_driver/heads/common/zoom_table.hpp"
#include "ptz_driver/heads/onvif/head/onvif_model.hpp"
#include "ptz_driver/heads/visca/visca_model.hpp"

namespace ptz::driver {
namespace {

constexpr double kDegPerRad = 180 / M_PI;

bool isOnvif(const std::string& backend) {
  return backend == "onvif";
}

double mean(const std::array<double, 2>& v) {
  return (v[0] + v[1]) / 2;
}

std::vector<double> meanZoomRatios(const UnitMap& map) {
  std::vector<double> out(map.zoom_units.size());
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = (map.zoom_ratios[0][i] + map.zoom_ratios[1][i]) / 2;
  }
  return out;
}

std::string line(const char* pattern, double a, double b) {
  char text[200];
  std::snprintf(text, sizeof text, pattern, a, b);
  return text;
}

// The measurement per camera, as comments above the fields.
void writeReport(cv::FileStorage& fs, const UnitMap& map, const char* unit) {
  fs.writeComment(" Angle map measured by ptz-head-calibrate from image motion (left, right):");
  fs.writeComment(
      line(" pan %.6g, %.6g", map.pan_units_per_rad[0] / kDegPerRad,
           map.pan_units_per_rad[1] / kDegPerRad) +
      " " + unit + " per degree (rms of the moves about the line " +
      line("%.4f, %.4f deg)", map.pan_rms_rad[0] * kDegPerRad, map.pan_rms_rad[1] * kDegPerRad));
  fs.writeComment(
      line(" tilt %.6g, %.6g", map.tilt_units_per_rad[0] / kDegPerRad,
           map.tilt_units_per_rad[1] / kDegPerRad) +
      " " + unit + " per degree (rms " +
      line("%.4f, %.4f deg)", map.tilt_rms_rad[0] * kDegPerRad, map.tilt_rms_rad[1] * kDegPerRad));
  fs.writeComment(" zoom ratios at the zoom positions below, left / right:");
  for (size_t i = 0; i < map.zoom_units.size(); ++i) {
    fs.writeComment(line("   %.6g: ", map.zoom_units[i], 0) +
                    line("%.4f / %.4f", map.zoom_ratios[0][i], map.zoom_ratios[1][i]));
  }
}

cv::FileStorage openForWrite(const std::string& path) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception&) {
  }
  if (!fs.isOpened()) throw ConfigError("cannot write the model file '" + path + "'");
  return fs;
}

}  // namespace

UnitMapGuess guessFromModelFile(const std::string& backend, const std::string& path) {
  UnitMapGuess g;
  if (isOnvif(backend)) {
    const OnvifModel m = OnvifModel::load(path);
    g.home = {m.panNormalised(0), m.tiltNormalised(0), 0};
    g.pan_units_per_rad = 2 / (m.pan_max_rad - m.pan_min_rad);
    g.tilt_units_per_rad = 2 / (m.tilt_max_rad - m.tilt_min_rad);
    g.zoom_max_units = 1;
    g.zoom_ratio = [m](double u) { return m.zoomRatio(u); };
    return g;
  }
  const ViscaModel m = ViscaModel::load(path);
  g.home = {0, 0, m.zoom.positions.front()};
  g.pan_units_per_rad = m.pan_units_per_rad;
  g.tilt_units_per_rad = m.tilt_units_per_rad;
  g.zoom_max_units = m.zoom.positions.back();
  g.zoom_ratio = [t = m.zoom](double u) { return interpolate(t.positions, t.ratios, u); };
  g.unit_step = 1;
  return g;
}

void writeModelFile(const std::string& backend, const std::string& template_path,
                    const UnitMapGuess& guess, const UnitMap& map, const std::string& out_path) {
  const std::vector<double> ratios = meanZoomRatios(map);
  if (isOnvif(backend)) {
    const OnvifModel m = OnvifModel::load(template_path);
    // Linear over -1..1 with home where the file had it: x -> (x - home) / units_per_rad.
    const double pan_deg = kDegPerRad / mean(map.pan_units_per_rad);
    const double tilt_deg = kDegPerRad / mean(map.tilt_units_per_rad);
    cv::FileStorage fs = openForWrite(out_path);
    writeReport(fs, map, "normalised units");
    fs << "name" << m.name << "manufacturer" << m.manufacturer << "model" << m.model;
    fs << "pan_min_deg" << (-1 - guess.home.pan) * pan_deg;
    fs << "pan_max_deg" << (1 - guess.home.pan) * pan_deg;
    fs << "tilt_min_deg" << (-1 - guess.home.tilt) * tilt_deg;
    fs << "tilt_max_deg" << (1 - guess.home.tilt) * tilt_deg;
    fs << "pan_tilt_speed_max_deg_s" << m.pan_tilt_speed_max_rad_s * kDegPerRad;
    fs << "zoom_normalised" << map.zoom_units << "zoom_ratios" << ratios;
    fs << "cheap" << (m.cheap ? 1 : 0) << "status_delay_ms" << m.status_delay_ms;
    return;
  }
  const ViscaModel m = ViscaModel::load(template_path);
  cv::FileStorage fs = openForWrite(out_path);
  writeReport(fs, map, "units");
  fs << "name" << m.name << "pan_nibbles" << m.pan_nibbles;
  fs << "pan_units_per_deg" << mean(map.pan_units_per_rad) / kDegPerRad;
  fs << "tilt_units_per_deg" << mean(map.tilt_units_per_rad) / kDegPerRad;
  fs << "pan_min_deg" << m.pan_min_rad * kDegPerRad << "pan_max_deg" << m.pan_max_rad * kDegPerRad;
  fs << "tilt_min_deg" << m.tilt_min_rad * kDegPerRad << "tilt_max_deg"
     << m.tilt_max_rad * kDegPerRad;
  fs << "pan_speed_max" << m.pan_speed_max << "tilt_speed_max" << m.tilt_speed_max;
  fs << "zoom_positions" << map.zoom_units << "zoom_ratios" << ratios;
}

}  // namespace ptz::driver
