#include "ptz_driver/heads/zoom_table.hpp"

#include <algorithm>
#include <cmath>

#include "common/config.hpp"

namespace ptz::driver {

ZoomTable ZoomTable::read(const cv::FileNode& root, const std::string& where) {
  ZoomTable t;
  for (const auto& n : readNode(root, "zoom_positions", where))
    t.positions.push_back(static_cast<double>(n));
  for (const auto& n : readNode(root, "zoom_ratios", where))
    t.ratios.push_back(static_cast<double>(n));
  if (t.positions.size() < 2 || t.positions.size() != t.ratios.size() ||
      !std::is_sorted(t.positions.begin(), t.positions.end()) ||
      !std::is_sorted(t.ratios.begin(), t.ratios.end())) {
    throw ConfigError(where +
                      ": fields 'zoom_positions' and 'zoom_ratios' must be increasing "
                      "lists of the same length (at least 2)");
  }
  return t;
}

double interpolate(const std::vector<double>& from, const std::vector<double>& to, double x) {
  if (x <= from.front()) return to.front();
  if (x >= from.back()) return to.back();
  const auto it = std::upper_bound(from.begin(), from.end(), x);
  const size_t i = static_cast<size_t>(it - from.begin());
  const double a = (x - from[i - 1]) / (from[i] - from[i - 1]);
  return to[i - 1] + a * (to[i] - to[i - 1]);
}

int ZoomTable::position(double ratio) const {
  return static_cast<int>(std::lround(interpolate(ratios, positions, ratio)));
}

double ZoomTable::ratio(int position) const {
  return interpolate(positions, ratios, position);
}

}  // namespace ptz::driver
