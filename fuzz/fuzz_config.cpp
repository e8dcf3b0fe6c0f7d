// The config loader: Params::parseConfigFile on a YAML file written from the input, with the
// parameters a process declares (transport, plant and limits, image encoding, freshness, and one
// of each type with a range, an order and a section), then the readers processes use on them,
// ptz-detect's marker classes (section `markers`) among them.
// Properties: only ConfigError escapes, and a ConfigError of the file names the file; an
// accepted file leaves every value of the declared type, within its range and order.
#include <cmath>
#include <exception>

#include "common/config.hpp"
#include "common/freshness.hpp"
#include "common/markers.hpp"
#include "common/plant.hpp"
#include "common/transport/transport.hpp"
#include "fuzz/fuzz_support.hpp"
#include "perception/markers/marker_params.hpp"

namespace {

ptz::Params declare() {
  ptz::Params p("ptz-fuzz-config", "the parameters of a typical process");
  ptz::addTransportParams(p);
  ptz::addPlantParams(p);
  ptz::addImageEncodingParams(p);
  ptz::addFreshnessParams(p, "setpoint", 500.0, "a setpoint");
  p.add("rig_file", "", "rig file");
  p.add("frames", 0, "", "frames", ptz::Range::atLeast(0));
  p.add("frame_rate_hz", 30.0, "Hz", "frame rate", ptz::Range::above(0).andAtMost(1000));
  p.add("min_range_m", 0.5, "m", "nearest", ptz::Range::atLeast(0));
  p.add("max_range_m", 20.0, "m", "farthest", ptz::Range::above(0));
  p.addOrder("min_range_m", "max_range_m");
  p.add("show", false, "a switch");
  p.addSection("objects", "a list only the file can give");
  p.addSection("markers", "ptz-detect's fiducial marker classes");
  return p;
}

void checkAccepted(const ptz::Params& p) {
  const int frames = p.getInt("frames");
  FUZZ_CHECK(frames >= 0, "frames " + std::to_string(frames));
  const double rate = p.getDouble("frame_rate_hz");
  FUZZ_CHECK(rate > 0 && rate <= 1000, "frame_rate_hz " + std::to_string(rate));
  const double near = p.getDouble("min_range_m"), far = p.getDouble("max_range_m");
  FUZZ_CHECK(std::isfinite(near) && std::isfinite(far) && near >= 0 && near < far,
             "ranges " + std::to_string(near) + " .. " + std::to_string(far));
  const std::string show = p.getString("show");
  FUZZ_CHECK(show == "true" || show == "false", "bool stored as '" + show + "'");
  const ptz::PtzPlant::Params plant = ptz::plantParamsFrom(p);
  for (const ptz::AxisParams& a : plant.axis) {
    FUZZ_CHECK(a.min_position < a.max_position && std::isfinite(a.min_position) &&
                   std::isfinite(a.max_position) && a.max_rate_per_s > 0 && a.gain > 0 &&
                   a.time_constant_s > 0 && a.dead_time_s >= 0 && std::isfinite(a.dead_time_s),
               "an axis of the plant out of its ranges");
  }
  FUZZ_CHECK(plant.step_s > 0 && plant.step_s <= 1, "plant_step_s " + std::to_string(plant.step_s));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ptz::fuzz::InputFile file(data, size, "config.yaml");
  ptz::Params p = declare();
  try {
    p.parseConfigFile(file.path());
  } catch (const ptz::ConfigError& e) {
    FUZZ_CHECK(ptz::fuzz::names(e.what(), file.path()),
               std::string("error without the file: ") + e.what());
    return 0;
  }
  try {
    checkAccepted(p);
    ptz::imageEncodingFrom(p);
    const ptz::FreshnessLimits limits = ptz::freshnessFrom(p, "setpoint");
    FUZZ_CHECK(limits.max_age_us > 0 && limits.future_tolerance_us >= 0,
               "freshness limits " + std::to_string(limits.max_age_us) + ", " +
                   std::to_string(limits.future_tolerance_us));
    (void)p.section("objects");
  } catch (const ptz::ConfigError&) {
    // A value the file gave that a reader refuses: the right answer.
  }
  // ptz-detect's marker classes: refused naming the file, or each within what it promises.
  try {
    const std::string where = "config file '" + file.path() + "'";
    for (const auto& c : ptz::perception::markerClassesFromConfig(p.section("markers"), where)) {
      FUZZ_CHECK(!c.name.empty() && c.name.find('#') == std::string::npos, "name '" + c.name + "'");
      FUZZ_CHECK(c.size_m >= 0.001 && c.size_m <= 10, "size_m " + std::to_string(c.size_m));
      const int count = ptz::markerFamilyCount(c.family);
      FUZZ_CHECK(count > 0, "family '" + c.family + "'");
      for (int id : c.ids) FUZZ_CHECK(id >= 0 && id < count, "id " + std::to_string(id));
      for (const auto& t : c.bundle) {
        FUZZ_CHECK(t.id >= 0 && t.id < count && t.centre_m.allFinite() &&
                       t.rotation_object_tag.allFinite(),
                   "bundle tag " + std::to_string(t.id));
      }
      FUZZ_CHECK(std::isfinite(c.radiusM()), "radius");
    }
  } catch (const ptz::ConfigError& e) {
    FUZZ_CHECK(ptz::fuzz::names(e.what(), file.path()),
               std::string("markers error without the file: ") + e.what());
  }
  return 0;
}
