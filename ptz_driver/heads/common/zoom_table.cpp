#include "ptz_driver/heads/common/zoom_table.hpp"

#include <algorithm>
#include <cmath>

#include "common/config.hpp"

namespace ptz::driver {

std::vector<double> readIncreasing(const cv::FileNode& root, const std::string& field,
                                   const std::string& where, const Range& range) {
  const std::vector<double> v = readNumberList(root, field, where, range, 2);
  for (size_t i = 1; i < v.size(); ++i) {
    checkFieldOrder(v[i - 1], v[i], where, field + "[" + std::to_string(i - 1) + "]",
                    field + "[" + std::to_string(i) + "]");
  }
  return v;
}

ZoomTable ZoomTable::read(const cv::FileNode& root, const std::string& where) {
  ZoomTable t;
  t.positions = readIncreasing(root, "zoom_positions", where, Range::between(0, 65535));
  t.ratios = readIncreasing(root, "zoom_ratios", where, Range::above(0));
  if (t.positions.size() != t.ratios.size()) {
    throw ConfigError(fieldPath(where, "zoom_ratios") + ": must have as many entries as " +
                      "zoom_positions (" + std::to_string(t.positions.size()) + "), got " +
                      std::to_string(t.ratios.size()));
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
