// The light a simulated camera sees beyond the scene's colours (issue #32): the scene's
// brightness changing over time (clouds, a lamp dimmed: keyframes, linear between them), mains
// flicker, the light's colour and the lens's vignetting; and each camera's auto-exposure and auto
// white balance. Applied to each rendered image before the sensor's noise; all off by default,
// which leaves every image as it was, byte for byte. And where the light comes from over time
// (the objects' shading) and the shadows the objects cast on the floor, which the renderer draws.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace ptz::sim {

struct Light {
  // Brightness over time: the scene's radiance times brightness[i] at brightness_s[i], linear
  // between, held before the first and after the last (empty: 1).
  std::vector<double> brightness_s, brightness;
  double mains_hz = 0;       // lamps on mains of this frequency (50, 60) flicker at twice it
  double flicker_depth = 0;  // ... the light dipping by this share at the mains' zero crossings
  double vignetting = 0;     // the image corners' light lost (0.3: corners at 70 %), as r^2
  // The light's colour: gains on the blue, green and red channels (a warm lamp: 0.8, 1, 1.2).
  cv::Vec3d tint_bgr{1, 1, 1};
  // The cameras' auto-exposure (AutoExposure): the image's mean grey it steers to (0: off), how
  // fast (a first-order lag), its largest gain and smallest.
  double auto_exposure_target = 0;
  double auto_exposure_time_constant_s = 0.5;
  double auto_exposure_max_gain = 8;
  // The cameras' auto white balance (AutoWhiteBalance): how fast it follows (0: off).
  double auto_white_balance_time_constant_s = 0;
  // Where the light comes from over time: direction[i] (unit, head frame, y down, z forward,
  // toward the light) at direction_s[i], normalised linear interpolation between, held before the
  // first and after the last (empty: defaultToLight(), the light the objects always had).
  std::vector<double> direction_s;
  std::vector<Eigen::Vector3d> direction;
  // Shadows on the floor: a floor point whose way to the light an object blocks loses this share
  // of the light (the renderer darkens it by 1 - shadow_depth). None while the light is at or
  // below the horizon (its direction's y >= 0).
  bool shadows = false;
  double shadow_depth = 0.55;

  // The fixed light of the scenes before direction existed: above, left and behind the cameras.
  static const Eigen::Vector3d& defaultToLight();
  // The unit direction toward the light at t_s.
  Eigen::Vector3d toLightAt(double t_s) const;

  // The image's light (apply: brightness, flicker, vignetting, tint) is off; the direction and the
  // shadows are the renderer's.
  bool off() const;
  bool tinted() const { return tint_bgr != cv::Vec3d(1, 1, 1); }
  // The brightness times the flicker at t_s (a frame's exposure taken as instantaneous).
  double gainAt(double t_s) const;
  // bgr (8-bit) as lit at t_s; nothing when off().
  void apply(double t_s, cv::Mat* bgr) const;

  // The scene section's `light` map (absent: off, the default direction, no shadows); errors name
  // the file, the field and the value.
  static Light fromConfig(const cv::FileNode& light, const std::string& where);
};

// One camera's auto-exposure: a gain on its image that brings the image's mean grey to
// auto_exposure_target, following it with a first-order lag, so that the image brightens or
// darkens a while after the light or the view changed, as a real camera's does.
// A camera's first-order lag: the share of the way to its target a quantity moves between the
// frame before and t_s (0 at the first frame, and when time goes back).
class FirstOrderLag {
 public:
  double step(double t_s, double time_constant_s);

 private:
  double last_t_s_ = 0;
  bool started_ = false;
};

class AutoExposure {
 public:
  // bgr at the gain the earlier frames set; the gain then moves toward what this frame asks for.
  // Nothing when the light's auto_exposure_target is 0.
  void apply(const Light& light, double t_s, cv::Mat* bgr);
  double gain() const { return gain_; }

 private:
  double gain_ = 1;
  FirstOrderLag lag_;
};

// One camera's auto white balance, grey world: gains on blue and red that bring the image's mean
// blue and mean red to its mean green, following with a first-order lag (as AutoExposure), so
// that a view filled by a red poster turns less red a while after, as a real camera's does.
class AutoWhiteBalance {
 public:
  static constexpr double kMinGain = 0.25, kMaxGain = 4;
  // bgr at the gains the earlier frames set; the gains then move toward what this frame asks
  // for. Nothing when the light's auto_white_balance_time_constant_s is 0.
  void apply(const Light& light, double t_s, cv::Mat* bgr);
  double blueGain() const { return gain_b_; }
  double redGain() const { return gain_r_; }

 private:
  double gain_b_ = 1, gain_r_ = 1;
  FirstOrderLag lag_;
};

}  // namespace ptz::sim
