#include "sim/simulator.hpp"

namespace ptz::sim {

Simulator::Simulator(StereoRig rig, Scene scene, const PtzPlant::Params& plant, double noise_sigma,
                     unsigned seed)
    : rig_(std::move(rig)),
      scene_(std::make_unique<Scene>(std::move(scene))),
      plant_(plant, PtzPose{}, PtzPose{}),
      renderer_(*scene_),
      noise_(rig_.left.width, rig_.left.height, noise_sigma, seed) {}

SimFrame Simulator::capture() {
  SimFrame f;
  f.index = next_index_++;
  f.t_s = plant_.time();
  f.left_pose = plant_.pose(Side::kLeft);
  f.right_pose = plant_.pose(Side::kRight);
  renderer_.render(rig_.view(Side::kLeft, f.left_pose), f.t_s, &f.left);
  renderer_.render(rig_.view(Side::kRight, f.right_pose), f.t_s, &f.right);
  noise_.apply(static_cast<uint64_t>(f.index), 0, &f.left);
  noise_.apply(static_cast<uint64_t>(f.index), 1, &f.right);
  return f;
}

void Simulator::command(double t_s, const PtzPose& left, const PtzPose& right, int* clamped,
                        int* rejected) {
  plant_.command(t_s, left, right, clamped, rejected);
}

}  // namespace ptz::sim
