// The simulated rig without LCM: motors (PtzPlant), scene and rendering of both cameras.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/plant.hpp"
#include "common/rig.hpp"
#include "sim/render/renderer.hpp"
#include "sim/scene/scene.hpp"

namespace ptz::sim {

struct SimFrame {
  int64_t index = 0;
  double t_s = 0;
  cv::Mat left, right;  // BGR8
  PtzPose left_pose, right_pose;
  // The frame before's capture time and poses (none at the first): over a motion-blurred
  // exposure (Shutter) the heads move linearly from those to this frame's.
  bool has_earlier = false;
  double earlier_t_s = 0;
  PtzPose earlier_left_pose, earlier_right_pose;
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
  // One camera's image at the frame's time: one render, or with the shutter's exposure the mean
  // of renders over it (motion blur).
  void renderCamera(int camera, SimFrame* frame);
  // A head's pose at t_s during the frame's exposure: linear between the frame before's and the
  // frame's (beyond the frame before at the same rate, within the axes' limits).
  PtzPose poseDuringExposure(const SimFrame& f, Side side, double t_s) const;

  StereoRig rig_;
  std::unique_ptr<Scene> scene_;  // the renderer keeps a reference: a stable address
  PtzPlant plant_;
  Renderer left_renderer_, right_renderer_;  // one each: their caches stay warm
  NoiseBank noise_;
  std::array<AutoWhiteBalance, 2> white_balance_;  // left, right
  std::array<AutoExposure, 2> exposure_;           // left, right
  cv::Mat blur_sample_, blur_sum_;                 // motion blur's scratch
  int64_t next_index_ = 0;
  // The last snapshot's time and poses: the next frame's earlier ones.
  bool has_last_ = false;
  double last_t_s_ = 0;
  PtzPose last_left_, last_right_;
};

}  // namespace ptz::sim
