// The Pelco-D head model file loader (PelcoModel::load, config/pelco_d/*.yaml) on a file written
// from the input. Properties: only ConfigError escapes, naming the file; an accepted model maps
// every pan and tilt within its limits to 0..35999 centidegrees and back within a centidegree,
// and its zoom table is finite, increasing, with positions that fit the frame's 16 bits.
#include <cmath>

#include "common/config.hpp"
#include "fuzz/drivers/fuzz_model_support.hpp"
#include "ptz_driver/heads/pelco_d/pelco_model.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto loaded = ptz::fuzz::loadModel<ptz::driver::PelcoModel>(data, size, "pelco.yaml");
  if (!loaded) return 0;
  const ptz::driver::PelcoModel& m = *loaded;
  const auto& z = m.zoom;
  ptz::fuzz::checkZoomTable(z);
  FUZZ_CHECK(z.positions.front() >= 0 && z.positions.back() <= 0xFFFF,
             "zoom positions beyond 16 bits");
  const double centideg_rad = M_PI / 18000;
  for (double pan : {m.pan_min_rad, m.pan_max_rad}) {
    const int c = m.panCentideg(pan);
    FUZZ_CHECK(c >= 0 && c < 36000, "pan centidegrees " + std::to_string(c));
    FUZZ_CHECK(std::abs(m.panRad(c) - pan) <= centideg_rad, "pan does not come back");
  }
  for (double tilt : {m.tilt_min_rad, m.tilt_max_rad}) {
    const int c = m.tiltCentideg(tilt);
    FUZZ_CHECK(c >= 0 && c < 36000, "tilt centidegrees " + std::to_string(c));
    FUZZ_CHECK(std::abs(m.tiltRad(c) - tilt) <= centideg_rad, "tilt does not come back");
  }
  return 0;
}
