// Posters on the backdrop (issue #32): coloured rectangles or photographs on the backdrop plane,
// e.g. a red poster behind a red ball's path, a bright window for the auto-exposure, a real
// photograph the size of the view. The renderer draws them in its background pass: in front of
// the backdrop's texture, behind every object, hidden by the floor.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "common/rig.hpp"

namespace ptz::sim {

struct Poster {
  static constexpr size_t kMax = 16;
  // On the backdrop plane z = backdrop_distance_m, head frame (y down): its centre and its width
  // and height, m.
  Eigen::Vector2d centre_m = Eigen::Vector2d::Zero();
  Eigen::Vector2d size_m = Eigen::Vector2d::Ones();
  cv::Vec3b color_bgr{255, 255, 255};  // reflectance (255: white)
  double brightness = 1;               // radiance factor: a lit window 3 (saturating at 255)
  std::string image_path;              // a photograph stretched over it instead ("": none)
  // The photograph (BGR8, its columns along x, its rows along y) and its halvings, coarsest last:
  // each pixel reads the level as fine as its footprint, so a large photograph does not alias.
  std::vector<cv::Mat> image_levels;

  bool isPhotograph() const { return !image_levels.empty(); }
  bool contains(double x_m, double y_m) const {
    return std::abs(x_m - centre_m.x()) <= size_m.x() / 2 &&
           std::abs(y_m - centre_m.y()) <= size_m.y() / 2;
  }
  // The pixel whose ray meets the backdrop at (x_m, y_m) on this poster, its footprint there
  // footprint_m wide (a photograph's only); backdrop: the backdrop's colour there (a colour
  // poster keeps its texture).
  cv::Vec3b shade(double x_m, double y_m, double footprint_m, const cv::Vec3b& backdrop) const;
  // The same poster (its photograph the same pixels in memory).
  bool operator==(const Poster& o) const;
};

// The rays (normalised image coordinates x/z, y/z of a camera) that may see a poster: the box of
// its corners' (a rectangle in front of a camera looks like the hull of its corners), or every ray
// when a corner is not in front.
struct RayBox {
  double lo_x = HUGE_VAL, lo_y = HUGE_VAL, hi_x = -HUGE_VAL, hi_y = -HUGE_VAL;

  static RayBox of(const Poster& poster, const CameraView& view, double backdrop_distance_m);
  void add(double x, double y);
  void add(const RayBox& box);
  bool contains(float x, float y) const {
    constexpr double kMargin = 1e-4;  // the float rays' rounding, many times over
    return x >= lo_x - kMargin && x <= hi_x + kMargin && y >= lo_y - kMargin && y <= hi_y + kMargin;
  }
};

// The scene section's `posters` list (absent: none); an error names the file, the field and the
// value, an unreadable photograph also its path. Relative image paths are from base_dir (the
// config file's folder; empty: the current directory).
std::vector<Poster> readPosters(const cv::FileNode& list, const std::string& where,
                                const std::string& base_dir);

}  // namespace ptz::sim
