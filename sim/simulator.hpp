// The simulated rig without LCM: motors (PtzPlant), scene and rendering of both cameras.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/plant.hpp"
#include "common/rig.hpp"
#include "sim/renderer.hpp"
#include "sim/scene/scene.hpp"

namespace ptz::sim {

struct SimFrame {
  int64_t index = 0;
  double t_s = 0;
  cv::Mat left, right;  // BGR8
  PtzPose left_pose, right_pose;
  // Per camera (left, right), per scene object: its share of its pixels in the image that no
  // nearer object hides (Renderer::render); empty until rendered.
  std::array<std::vector<double>, 2> visible_fraction;
};

class Simulator {
 public:
  Simulator(StereoRig rig, Scene scene, const PtzPlant::Params& plant, double noise_sigma,
            unsigned seed);

  // Renders both cameras at the current sim time and the current motor state.
  SimFrame capture();
  // The same in two steps, so that the motors may move on while the images render (ptz-sim's
  // VISCA thread): the frame's time, index and poses; then its images from those.
  SimFrame snapshot();
  void render(SimFrame* frame);
  // A setpoint issued at sim time t_s (takes effect after the dead time).
  void command(double t_s, const PtzPose& left, const PtzPose& right, int* clamped, int* rejected);
  void advanceTo(double t_s) { plant_.advanceTo(t_s); }
  double time() const { return plant_.time(); }

  const StereoRig& rig() const { return rig_; }
  const Scene& scene() const { return *scene_; }
  const PtzPlant& plant() const { return plant_; }
  CameraView view(Side side) const { return rig_.view(side, plant_.pose(side)); }

 private:
  StereoRig rig_;
  std::unique_ptr<Scene> scene_;  // the renderer keeps a reference: a stable address
  PtzPlant plant_;
  Renderer left_renderer_, right_renderer_;  // one each: their caches stay warm
  NoiseBank noise_;
  std::array<AutoExposure, 2> exposure_;  // left, right
  int64_t next_index_ = 0;
};

}  // namespace ptz::sim
