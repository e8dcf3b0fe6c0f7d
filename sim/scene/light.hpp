// The light a simulated camera sees beyond the scene's colours (issue #32's first part): the
// scene's brightness changing over time (clouds, a lamp dimmed: keyframes, linear between them),
// mains flicker, and the lens's vignetting. Applied to each rendered image before the sensor's
// noise; all off by default, which leaves every image as it was, byte for byte.
#pragma once

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
  // The cameras' auto-exposure (AutoExposure): the image's mean grey it steers to (0: off), how
  // fast (a first-order lag), its largest gain and smallest.
  double auto_exposure_target = 0;
  double auto_exposure_time_constant_s = 0.5;
  double auto_exposure_max_gain = 8;

  bool off() const;
  // The brightness times the flicker at t_s (a frame's exposure taken as instantaneous).
  double gainAt(double t_s) const;
  // bgr (8-bit) as lit at t_s; nothing when off().
  void apply(double t_s, cv::Mat* bgr) const;

  // The scene section's `light` map (absent: off); errors name the file, the field and the value.
  static Light fromConfig(const cv::FileNode& light, const std::string& where);
};

// One camera's auto-exposure: a gain on its image that brings the image's mean grey to
// auto_exposure_target, following it with a first-order lag, so that the image brightens or
// darkens a while after the light or the view changed, as a real camera's does.
class AutoExposure {
 public:
  // bgr at the gain the earlier frames set; the gain then moves toward what this frame asks for.
  // Nothing when the light's auto_exposure_target is 0.
  void apply(const Light& light, double t_s, cv::Mat* bgr);
  double gain() const { return gain_; }

 private:
  double gain_ = 1;
  double last_t_s_ = 0;
  bool started_ = false;
};

}  // namespace ptz::sim
