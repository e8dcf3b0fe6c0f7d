// The VISCA camera model file loader (ViscaModel::load, config/visca/*.yaml) on a file written
// from the input. Properties: only ConfigError escapes, naming the file; an accepted model can be
// spoken: every pan and tilt within its limits fits the command's nibbles and comes back within a
// unit, the speeds fit a VISCA data byte (bit 7 clear), the zoom table is finite, increasing and
// its positions fit 4 nibbles.
#include <cmath>

#include "common/config.hpp"
#include "fuzz/drivers/fuzz_model_support.hpp"
#include "ptz_driver/heads/visca/visca_model.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto loaded = ptz::fuzz::loadModel<ptz::driver::ViscaModel>(data, size, "visca.yaml");
  if (!loaded) return 0;
  const ptz::driver::ViscaModel& m = *loaded;
  FUZZ_CHECK(m.pan_nibbles == 4 || m.pan_nibbles == 5,
             "pan_nibbles " + std::to_string(m.pan_nibbles));
  FUZZ_CHECK(std::isfinite(m.pan_units_per_rad) && m.pan_units_per_rad > 0 &&
                 std::isfinite(m.tilt_units_per_rad) && m.tilt_units_per_rad > 0,
             "units per radian");
  FUZZ_CHECK(std::isfinite(m.pan_min_rad) && std::isfinite(m.pan_max_rad) &&
                 m.pan_min_rad < m.pan_max_rad && std::isfinite(m.tilt_min_rad) &&
                 std::isfinite(m.tilt_max_rad) && m.tilt_min_rad < m.tilt_max_rad,
             "limits");
  FUZZ_CHECK(m.pan_speed_max >= 1 && m.pan_speed_max <= 0x7F && m.tilt_speed_max >= 1 &&
                 m.tilt_speed_max <= 0x7F,
             "speeds " + std::to_string(m.pan_speed_max) + ", " + std::to_string(m.tilt_speed_max) +
                 " do not fit a VISCA data byte");
  ptz::fuzz::checkZoomTable(m.zoom);
  FUZZ_CHECK(m.zoom.positions.front() >= 0 && m.zoom.positions.back() <= 0xFFFF,
             "zoom positions beyond 4 nibbles");
  const int32_t pan_limit = 1 << (4 * m.pan_nibbles - 1);
  for (double pan : {m.pan_min_rad, m.pan_max_rad, 0.5 * (m.pan_min_rad + m.pan_max_rad)}) {
    const int32_t units = m.panUnits(pan);
    FUZZ_CHECK(units >= -pan_limit && units < pan_limit, "pan " + std::to_string(pan) + " rad is " +
                                                             std::to_string(units) +
                                                             " units, beyond the nibbles");
    FUZZ_CHECK(std::abs(m.panRad(units) - pan) * m.pan_units_per_rad <= 0.5 + 1e-6,
               "pan does not come back");
  }
  for (double tilt : {m.tilt_min_rad, m.tilt_max_rad}) {
    const int32_t units = m.tiltUnits(tilt);
    FUZZ_CHECK(units >= -32768 && units < 32768,
               "tilt " + std::to_string(tilt) + " rad is " + std::to_string(units) + " units");
  }
  return 0;
}
