// The model files whose angle map ptz-head-calibrate measures: the guess it starts from (the
// file at hand) and the file it writes (that file with the measured map, the rest kept).
#pragma once

#include <string>

#include "ptz_driver/head_calibrate/head_calibration.hpp"

namespace ptz::driver {

// backend: onvif (an ONVIF model file, config/onvif/) or visca_ip / visca_serial (a VISCA model
// file, config/visca/). Throws ConfigError naming the file and the field.
UnitMapGuess guessFromModelFile(const std::string& backend, const std::string& path);

// Writes the model file at template_path with the map measured (both cameras' mean) to out_path;
// the numbers per camera go in its comments. Throws ConfigError naming out_path when it cannot.
void writeModelFile(const std::string& backend, const std::string& template_path,
                    const UnitMapGuess& guess, const UnitMap& map, const std::string& out_path);

}  // namespace ptz::driver
