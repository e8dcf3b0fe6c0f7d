#include "sim/simulator.hpp"

#include <algorithm>

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
  f.has_earlier = has_last_;
  f.earlier_t_s = last_t_s_;
  f.earlier_left_pose = last_left_;
  f.earlier_right_pose = last_right_;
  has_last_ = true;
  last_t_s_ = f.t_s;
  last_left_ = f.left_pose;
  last_right_ = f.right_pose;
  return f;
}

PtzPose Simulator::poseDuringExposure(const SimFrame& f, Side side, double t_s) const {
  const PtzPose& now = side == Side::kLeft ? f.left_pose : f.right_pose;
  const double span_s = f.t_s - f.earlier_t_s;
  if (!f.has_earlier || !(span_s > 0)) return now;  // the first frame: the heads as they are
  const PtzPose& before = side == Side::kLeft ? f.earlier_left_pose : f.earlier_right_pose;
  const double a = (t_s - f.t_s) / span_s;  // 0 now, -1 at the frame before
  const auto at = [&](PtzPlant::Axis axis, double then, double current) {
    const AxisParams& limits = plant_.axis(side, axis).params();
    return std::clamp(current + a * (current - then), limits.min_position, limits.max_position);
  };
  return {at(PtzPlant::kPan, before.pan_rad, now.pan_rad),
          at(PtzPlant::kTilt, before.tilt_rad, now.tilt_rad),
          at(PtzPlant::kZoom, before.zoom, now.zoom)};
}

void Simulator::renderCamera(int camera, SimFrame* frame) {
  SimFrame& f = *frame;
  const Side side = camera == 0 ? Side::kLeft : Side::kRight;
  Renderer& renderer = camera == 0 ? left_renderer_ : right_renderer_;
  cv::Mat* image = camera == 0 ? &f.left : &f.right;
  std::vector<double>* visible = &f.visible_fraction[static_cast<size_t>(camera)];
  const Shutter& shutter = scene_->camera;
  if (shutter.exposure_s <= 0) {
    renderer.render(rig_.view(side, side == Side::kLeft ? f.left_pose : f.right_pose), f.t_s, image,
                    visible);
    return;
  }
  // Renders at times spread evenly over [t - exposure / 2, t + exposure / 2]: the frame's time is
  // its exposure's middle, where a smeared object's centroid is (the visible fractions are the
  // middle sample's). Summed in 16 bits (16 x 255 fits) and rounded once.
  const int n = shutter.blur_samples;
  for (int i = 0; i < n; ++i) {
    const double t_s = f.t_s + shutter.exposure_s * (static_cast<double>(i) / (n - 1) - 0.5);
    renderer.render(rig_.view(side, poseDuringExposure(f, side, t_s)), t_s, &blur_sample_,
                    i == n / 2 ? visible : nullptr);
    if (i == 0) {
      blur_sample_.convertTo(blur_sum_, CV_16U);
    } else {
      cv::add(blur_sum_, blur_sample_, blur_sum_, cv::noArray(), CV_16U);
    }
  }
  blur_sum_.convertTo(*image, CV_8U, 1.0 / n);
}

void Simulator::render(SimFrame* frame) {
  SimFrame& f = *frame;
  // One camera after the other, each on all cores in bands of rows (Renderer::render,
  // NoiseBank::apply): balanced whatever each camera sees, and byte-identical to one thread.
  for (int camera = 0; camera < 2; ++camera) {
    cv::Mat* image = camera == 0 ? &f.left : &f.right;
    renderCamera(camera, frame);
    // The scene's light (its colour) and the lens, the camera's white balance and exposure, then
    // the sensor's noise.
    scene_->light.apply(f.t_s, image);
    white_balance_[static_cast<size_t>(camera)].apply(scene_->light, f.t_s, image);
    exposure_[static_cast<size_t>(camera)].apply(scene_->light, f.t_s, image);
    noise_.apply(static_cast<uint64_t>(f.index), camera, image);
  }
}

void Simulator::command(double t_s, const PtzPose& left, const PtzPose& right, int* clamped,
                        int* rejected) {
  plant_.command(t_s, left, right, clamped, rejected);
}

}  // namespace ptz::sim
