// A still stereo frame of a scene with both cameras aimed at a point, as ptz-sim sends it (its
// pixel noise, JPEG q90 and back): motors that reach their setpoint at once; crops of it.
#pragma once

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "perception/detection/windows.hpp"
#include "sim/simulator.hpp"

namespace ptz::test {

inline cv::Mat jpegRoundTrip(const cv::Mat& bgr) {
  std::vector<uchar> bytes;
  cv::imencode(".jpg", bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, 90});
  return cv::imdecode(bytes, cv::IMREAD_COLOR);
}

struct AimedFrame {
  cv::Mat left, right;  // BGR, through JPEG
  CameraView left_view, right_view;
};

// Each camera turned from where it stands towards `aim` (head frame) at `zoom`; the frame at 0.05
// s.
inline AimedFrame renderAimed(const StereoRig& rig, const sim::Scene& scene,
                              const Eigen::Vector3d& aim, double zoom) {
  auto plant = defaultPlantParams();
  for (auto& a : plant.axis) {
    a.time_constant_s = 1e-4;
    a.max_rate_per_s = 1e6;
  }
  sim::Simulator s(rig, scene, plant, 2.0, 3);
  auto pose = [&](Side side) {
    const Eigen::Vector3d d = aim - rig.view(side, {}).position_head_m;
    return PtzPose{std::atan2(d.x(), d.z()), std::atan2(-d.y(), std::hypot(d.x(), d.z())), zoom};
  };
  int clamped = 0, rejected = 0;
  s.command(0, pose(Side::kLeft), pose(Side::kRight), &clamped, &rejected);
  s.advanceTo(0.05);
  const sim::SimFrame f = s.capture();
  return {jpegRoundTrip(f.left), jpegRoundTrip(f.right), rig.view(Side::kLeft, f.left_pose),
          rig.view(Side::kRight, f.right_pose)};
}

// Both cameras at home (the rig's default) looking at the scene at time t_s.
inline AimedFrame renderAtHome(const sim::Scene& scene, double t_s) {
  sim::Simulator s(StereoRig::makeDefault(), scene, defaultPlantParams(), 2.0, 3);
  s.advanceTo(t_s);
  const sim::SimFrame f = s.capture();
  const StereoRig rig = StereoRig::makeDefault();
  return {jpegRoundTrip(f.left), jpegRoundTrip(f.right), rig.view(Side::kLeft, f.left_pose),
          rig.view(Side::kRight, f.right_pose)};
}

// Crops of a frame's two images, as ptz-detect's FramePixels gives them.
struct FrameCrops {
  cv::Mat images[2];
  perception::CropPixels crop[2] = {[this](const cv::Rect& r, cv::Mat* out, std::string*) {
                                      *out = images[0](r).clone();
                                      return true;
                                    },
                                    [this](const cv::Rect& r, cv::Mat* out, std::string*) {
                                      *out = images[1](r).clone();
                                      return true;
                                    }};
};

}  // namespace ptz::test
