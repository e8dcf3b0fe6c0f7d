// What the two camera model file targets (VISCA, Pelco-D) share: the load of a file written from
// the input, and the properties of an accepted zoom table.
#pragma once

#include <cmath>
#include <optional>
#include <string>

#include "common/config.hpp"
#include "fuzz/fuzz_support.hpp"
#include "ptz_driver/heads/common/zoom_table.hpp"

namespace ptz::fuzz {

// Model::load on the input as a file; nullopt when refused (only ConfigError, naming the file).
template <class Model>
std::optional<Model> loadModel(const uint8_t* data, size_t size, const char* name) {
  const InputFile file(data, size, name);
  try {
    return Model::load(file.path());
  } catch (const ConfigError& e) {
    FUZZ_CHECK(names(e.what(), file.path()), std::string("error without the file: ") + e.what());
    return std::nullopt;
  }
}

// Finite, increasing in both columns, at least two entries.
inline void checkZoomTable(const driver::ZoomTable& z) {
  FUZZ_CHECK(z.positions.size() >= 2 && z.positions.size() == z.ratios.size(), "zoom table size");
  for (size_t i = 0; i < z.positions.size(); ++i) {
    FUZZ_CHECK(std::isfinite(z.positions[i]) && std::isfinite(z.ratios[i]) && z.ratios[i] > 0,
               "zoom table entry " + std::to_string(i) + " not finite or ratio <= 0");
    FUZZ_CHECK(i == 0 || (z.positions[i] > z.positions[i - 1] && z.ratios[i] > z.ratios[i - 1]),
               "zoom table not increasing at " + std::to_string(i));
  }
}

}  // namespace ptz::fuzz
