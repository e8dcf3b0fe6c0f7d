#include "sim/simulator.hpp"

namespace ptz::sim {

Simulator::Simulator(StereoRig rig, Scene scene, const PtzPlant::Params& plant, double noise_sigma,
                     unsigned seed)
    : rig_(std::move(rig)),
      scene_(std::make_unique<Scene>(std::move(scene))),
      plant_(plant, PtzPose{}, PtzPose{}),
      left_renderer_(*scene_),
      right_renderer_(*scene_),
      noise_(rig_.left.width, rig_.left.height, noise_sigma, seed) {}

SimFrame Simulator::capture() {
  SimFrame f = snapshot();
  render(&f);
  return f;
}

SimFrame Simulator::snapshot() {
  SimFrame f;
  f.index = next_index_++;
  f.t_s = plant_.time();
  f.left_pose = plant_.pose(Side::kLeft);
  f.right_pose = plant_.pose(Side::kRight);
  return f;
}

void Simulator::render(SimFrame* frame) {
  SimFrame& f = *frame;
  const CameraView left = rig_.view(Side::kLeft, f.left_pose);
  const CameraView right = rig_.view(Side::kRight, f.right_pose);
  // One camera after the other, each on all cores in bands of rows (Renderer::render,
  // NoiseBank::apply): balanced whatever each camera sees, and byte-identical to one thread.
  for (int camera = 0; camera < 2; ++camera) {
    cv::Mat* image = camera == 0 ? &f.left : &f.right;
    (camera == 0 ? left_renderer_ : right_renderer_)
        .render(camera == 0 ? left : right, f.t_s, image,
                &f.visible_fraction[static_cast<size_t>(camera)]);
    // The scene's light and the lens, the camera's exposure, then the sensor's noise.
    scene_->light.apply(f.t_s, image);
    exposure_[static_cast<size_t>(camera)].apply(scene_->light, f.t_s, image);
    noise_.apply(static_cast<uint64_t>(f.index), camera, image);
  }
}

void Simulator::command(double t_s, const PtzPose& left, const PtzPose& right, int* clamped,
                        int* rejected) {
  plant_.command(t_s, left, right, clamped, rejected);
}

}  // namespace ptz::sim
