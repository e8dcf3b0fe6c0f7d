// A head's zoom position (its own integer units) against the optical zoom ratio: an increasing
// table from a model file, interpolated linearly. Shared by the VISCA and Pelco-D model files.
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "common/config.hpp"  // Range

namespace ptz::driver {

struct ZoomTable {
  std::vector<double> positions, ratios;  // increasing, same length, at least 2

  // Reads fields 'zoom_positions' and 'zoom_ratios' of root; throws ConfigError naming `where`.
  static ZoomTable read(const cv::FileNode& root, const std::string& where);
  int position(double ratio) const;  // clamped to the table
  double ratio(int position) const;  // clamped to the table
};

// At least two strictly increasing numbers within `range` (a model file's table column).
std::vector<double> readIncreasing(const cv::FileNode& root, const std::string& field,
                                   const std::string& where, const Range& range);

// Piecewise-linear lookup of x in the increasing table from -> to, clamped at both ends.
double interpolate(const std::vector<double>& from, const std::vector<double>& to, double x);

}  // namespace ptz::driver
