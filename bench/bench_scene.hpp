// What the detector benchmarks share: a simulated scene of config/ rendered at a size, its rig,
// and the default colour classes (each run's baseline).
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include <string>

#include "common/rig.hpp"
#include "perception/detection/detector.hpp"
#include "sim/simulator.hpp"

namespace ptz::bench {

struct BenchScene {
  // sim_file: a file name in config/ (its scene, objects and chessboard sections).
  BenchScene(const std::string& sim_file, int width, int height)
      : scene(load(sim_file)),
        rig(StereoRig::makeDefault().atSize(width, height)),
        sim(rig, scene, defaultPlantParams(), 2.0, 1),
        colours(perception::DetectorParams::fromConfig(
            cv::FileStorage(PTZ_SOURCE_DIR "/config/detect_default.yaml",
                            cv::FileStorage::READ)["classes"],
            "detect_default.yaml")) {}

  // The frame at t_s, and the cameras' views of it.
  sim::SimFrame frameAt(double t_s, CameraView* left, CameraView* right) {
    sim.advanceTo(t_s);
    sim::SimFrame f = sim.capture();
    *left = rig.view(Side::kLeft, f.left_pose);
    *right = rig.view(Side::kRight, f.right_pose);
    return f;
  }

  sim::Scene scene;
  StereoRig rig;
  sim::Simulator sim;
  const perception::Detector colours;

 private:
  static sim::Scene load(const std::string& sim_file) {
    cv::FileStorage fs(PTZ_SOURCE_DIR "/config/" + sim_file, cv::FileStorage::READ);
    return sim::Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"], sim_file);
  }
};

// A detector bench's main: its run at VGA and at 1080p, on one core.
inline int runAtVgaAnd1080p(void (*run)(const char* size_name, int width, int height)) {
  cv::setNumThreads(1);
  run("VGA", 640, 480);
  run("1080p", 1920, 1080);
  return 0;
}

}  // namespace ptz::bench
