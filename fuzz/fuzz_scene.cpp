// The simulator's scenario: a config file written from the input, parsed as ptz-sim parses its
// own (Params with the sections scene, objects and chessboard), then Scene::fromConfig on the
// sections. The parameters mirror sim/sim_main.cpp's declaration, so that the project's sim
// configs are accepted seeds. Properties: only ConfigError escapes, naming the file; an accepted
// scene has finite, positive sizes, colours in range, trajectories finite at every time and a
// chessboard whose corners are finite.
#include <cmath>

#include "common/config.hpp"
#include "common/freshness.hpp"
#include "common/plant.hpp"
#include "common/transport/transport.hpp"
#include "fuzz/fuzz_support.hpp"
#include "sim/scene/scene.hpp"

namespace {

ptz::Params declare() {
  ptz::Params p("ptz-sim", "the simulator's parameters and sections");
  ptz::addTransportParams(p);
  ptz::addPlantParams(p);
  p.add("rig_file", "", "rig file");
  p.add("clock", "realtime", "realtime or lockstep");
  p.add("frame_rate_hz", 30.0, "Hz", "frame rate");
  p.add("frames", 0, "", "frames");
  p.add("duration_s", 0.0, "s", "duration");
  ptz::addImageEncodingParams(p);
  p.add("noise_sigma", 2.0, "grey levels", "noise");
  p.add("seed", 1, "", "seed");
  p.add("state_rate_hz", 100.0, "Hz", "state rate");
  p.add("lockstep_timeout_ms", 1000.0, "ms", "lockstep timeout");
  ptz::addFreshnessParams(p, "setpoint", 500.0, "a setpoint");
  p.add("visca_port", 0, "", "VISCA port");
  p.add("visca_model", "", "VISCA model file");
  p.addSection("scene", "the world");
  p.addSection("objects", "the objects");
  p.addSection("chessboard", "the board");
  return p;
}

void checkObject(const ptz::sim::SceneObject& o, const std::string& name) {
  if (o.shape == ptz::sim::SceneObject::Shape::kSphere) {
    FUZZ_CHECK(std::isfinite(o.radius_m) && o.radius_m > 0, name + " radius");
  } else if (o.shape == ptz::sim::SceneObject::Shape::kPerson) {
    FUZZ_CHECK(std::isfinite(o.height_m) && o.height_m > 0 && std::isfinite(o.yaw_rad),
               name + " person");
  } else {
    FUZZ_CHECK(o.half_extents_m.allFinite() && (o.half_extents_m.array() > 0).all() &&
                   std::isfinite(o.yaw_rad),
               name + " box");
  }
  FUZZ_CHECK(std::isfinite(o.boundingRadius()), name + " bounding radius");
  const ptz::sim::Trajectory& t = o.trajectory;
  FUZZ_CHECK(std::isfinite(t.period_s) && t.period_s > 0 && std::isfinite(t.phase_rad) &&
                 t.centre_m.allFinite() && t.amplitude_m.allFinite(),
             name + " trajectory");
  for (double time_s : {0.0, 0.37, 12.5, 3600.0}) {
    FUZZ_CHECK(t.position(time_s).allFinite(),
               name + " position not finite at t = " + std::to_string(time_s));
  }
}

void checkScene(const ptz::sim::Scene& s) {
  FUZZ_CHECK(std::isfinite(s.backdrop_distance_m) && s.backdrop_distance_m > 0.5 &&
                 std::isfinite(s.floor_height_m) && std::isfinite(s.texture_m_per_texel) &&
                 s.texture_m_per_texel > 0,
             "scene numbers");
  for (size_t i = 0; i < s.objects.size(); ++i) {
    checkObject(s.objects[i], "objects[" + std::to_string(i) + "]");
  }
  // The light's direction a unit vector whenever asked; posters, shutter and shadows in range.
  for (double time_s : {0.0, 0.37, 12.5, 3600.0}) {
    const Eigen::Vector3d to_light = s.light.toLightAt(time_s);
    FUZZ_CHECK(to_light.allFinite() && std::abs(to_light.norm() - 1) < 1e-9, "light direction");
  }
  FUZZ_CHECK(s.light.shadow_depth >= 0 && s.light.shadow_depth <= 1, "shadow depth");
  FUZZ_CHECK(s.posters.size() <= ptz::sim::Poster::kMax, "posters");
  for (const ptz::sim::Poster& poster : s.posters) {
    FUZZ_CHECK(poster.centre_m.allFinite() && (poster.size_m.array() > 0).all() &&
                   poster.size_m.allFinite() && poster.brightness >= 0 && poster.brightness <= 10,
               "poster numbers");
  }
  FUZZ_CHECK(s.camera.exposure_s >= 0 && s.camera.exposure_s <= 0.2 && s.camera.blur_samples >= 2 &&
                 s.camera.blur_samples <= 16,
             "shutter");
  const ptz::sim::Chessboard& b = s.chessboard;
  if (!b.present) return;
  FUZZ_CHECK(b.inner_cols >= 2 && b.inner_rows >= 2 && std::isfinite(b.square_m) &&
                 b.square_m > 0 && b.rotation_head_board.allFinite() && b.centre_head_m.allFinite(),
             "chessboard numbers");
  for (const Eigen::Vector3d& c : b.innerCorners()) FUZZ_CHECK(c.allFinite(), "chessboard corner");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const ptz::fuzz::InputFile file(data, size, "sim.yaml");
  ptz::Params p = declare();
  try {
    p.parseConfigFile(file.path());
    const std::string where = "config file '" + file.path() + "'";
    const ptz::sim::Scene scene = ptz::sim::Scene::fromConfig(
        p.section("scene"), p.section("objects"), p.section("chessboard"), where);
    checkScene(scene);
  } catch (const ptz::ConfigError& e) {
    FUZZ_CHECK(ptz::fuzz::names(e.what(), file.path()),
               std::string("error without the file: ") + e.what());
  }
  return 0;
}
