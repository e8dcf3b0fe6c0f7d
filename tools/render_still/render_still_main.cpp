// ptz-render-still: renders one stereo frame of a ptz-sim scenario to PNG files, without LCM;
// for looking at a scenario before running it.
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "common/config.hpp"
#include "sim/simulator.hpp"

int main(int argc, char** argv) {
  using namespace ptz;
  Params p("ptz-render-still",
           "Renders the stereo pair of a ptz-sim scenario at one time and "
           "pose to <out>_left.png and <out>_right.png.");
  addAxisLimitParams(p);
  declareRigParams(p);
  p.add("time_s", 0.0, "s", "scene time", Range::atLeast(0));
  p.add("pan_rad", 0.0, "rad", "pan of both cameras", Range::between(-6.3, 6.3));
  p.add("tilt_rad", 0.0, "rad", "tilt of both cameras", Range::between(-6.3, 6.3));
  p.add("zoom", 1.0, "", "zoom ratio of both cameras", Range::above(0));
  p.add("noise_sigma", 2.0, "grey levels", "pixel noise", Range::between(0, 255));
  p.add("out", "still", "output file prefix");
  // A ptz-sim config file reads as it is; what only moves or streams does not make a still.
  for (const char* ignored : {"clock", "encoding"}) p.add(ignored, "", "ignored (ptz-sim's)");
  for (const char* ignored :
       {"frame_rate_hz", "dead_time_s", "plant_step_s", "pan_gain", "pan_time_constant_s",
        "tilt_gain", "tilt_time_constant_s", "zoom_gain", "zoom_time_constant_s"}) {
    p.add(ignored, 0.0, "", "ignored (ptz-sim's motor model and rate)");
  }
  p.addSection("scene", "as ptz-sim");
  p.addSection("objects", "as ptz-sim");
  p.addSection("chessboard", "as ptz-sim");
  try {
    if (!p.parse(argc, argv)) return 0;
    const std::string where = "config file '" + p.configPath() + "'";
    // A poster's photograph is found beside the config file, as ptz-sim finds it.
    const std::string config_dir = std::filesystem::path(p.configPath()).parent_path().string();
    sim::Scene scene = sim::Scene::fromConfig(p.section("scene"), p.section("objects"),
                                              p.section("chessboard"), where, config_dir);
    const StereoRig rig = rigFromParams(p);
    PtzPlant::Params plant = axisLimitsFrom(p);
    for (auto& axis : plant.axis) {  // motors reach the pose at once (gain 1)
      axis.dead_time_s = 0;
      axis.time_constant_s = 1e-4;
      axis.max_rate_per_s = 1e6;
    }
    sim::Simulator sim(rig, scene, plant, p.getDouble("noise_sigma"), 1);
    const PtzPose pose{p.getDouble("pan_rad"), p.getDouble("tilt_rad"), p.getDouble("zoom")};
    int clamped = 0, rejected = 0;
    sim.command(0, pose, pose, &clamped, &rejected);
    sim.advanceTo(std::max(p.getDouble("time_s"), 0.01));
    sim::SimFrame f = sim.capture();
    cv::imwrite(p.getString("out") + "_left.png", f.left);
    cv::imwrite(p.getString("out") + "_right.png", f.right);
    std::printf("wrote %s_left.png and %s_right.png (t = %.2f s)\n", p.getString("out").c_str(),
                p.getString("out").c_str(), f.t_s);
    return 0;
  } catch (const ConfigError& e) {
    std::fprintf(stderr, "ptz-render-still: %s\n", e.what());
    return 2;
  }
}
