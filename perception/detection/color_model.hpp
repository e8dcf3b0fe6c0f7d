// Colour detection that survives real light (issue #32): a class's intensity limit taken
// relative to how bright the class's own pixels are (an exposure's or a lamp's gain scales
// intensity, not hue or saturation), and a hue model that follows the tracked object (learned
// from its confirmed regions, inside the class's configured window, so it can narrow the class to
// the object's own hue but never move it elsewhere), so that clutter of a near hue stops merging
// with it. And what a class's appearance does against its configured range, for the status.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ptz::perception {

struct ColorAdaptParams {
  // A class's pixels need an intensity of only this share of its bright pixels' (the 95th
  // percentile of the pixels in the class's hue and saturation in the scanned part), when that is
  // below the class's intensity_min; never below intensity_floor. 0: intensity_min alone.
  double intensity_min_fraction = 0.25;
  double intensity_floor = 4;  // grey levels: where the sensor's noise decides the hue
  // The hue model: on, how many sigmas of the object's hue it keeps, never narrower than
  // follow_min_halfwidth_deg, learning_rate of a confirmed region's hue per frame, active after
  // follow_min_updates of them and until follow_forget_s without one.
  bool follow = true;
  double follow_sigmas = 3;
  double follow_min_halfwidth_deg = 4;
  // The sensor's noise (grey levels): a pixel of little chroma C has a hue this noisy, about
  // sqrt(1.5) noise / C radians; the gate widens by follow_sigmas of that (a dark side's pixels).
  double follow_noise_grey = 2;
  double follow_learning_rate = 0.1;
  int follow_min_updates = 5;
  double follow_forget_s = 2;
};

// The hue a class's pixels must also have: within halfwidth_deg of the class window's centre plus
// offset_deg (inactive: the window alone).
struct HueGate {
  bool active = false;
  double offset_deg = 0;
  double halfwidth_deg = 180;
};

// A region's colour, measured on its (filtered) pixels: the hue's mean offset from its class
// window's centre and spread, the mean saturation and intensity (pixels 0: not measured).
struct RegionColour {
  int pixels = 0;
  double hue_offset_deg = 0, hue_sigma_deg = 0;
  double saturation = 0, saturation_sigma = 0;
  double intensity = 0;
};

struct ColorClass;

// Two regions' colours (a stereo pair's) as one, weighted by their pixels.
RegionColour mergeColours(const RegionColour& a, const RegionColour& b);

// One class's model of its tracked object's colour.
class ColorModel {
 public:
  // A confirmed region of the tracked object at t_s (once a frame).
  void learn(const RegionColour& c, double t_s, const ColorAdaptParams& p);
  HueGate gate(double t_s, const ColorAdaptParams& p) const;
  // Learned from within follow_forget_s before t_s (a time before the last: a new run, not).
  bool recent(double t_s, const ColorAdaptParams& p) const;
  void reset() { *this = ColorModel(); }
  // Where the object's colour as last measured leaves the class's configured limits: its hue band
  // as the gate takes it (mean +- max(follow_sigmas sigma, follow_min_halfwidth_deg)), its
  // saturation's mean +- 2 sigma, its mean intensity. "" when inside; else e.g. "hue 17.5 +- 4.2
  // deg reaches the window 340 .. 20". intensity_min is judged as detection does (relative when
  // intensity_min_fraction).
  std::string outOfRange(const ColorClass& c, const ColorAdaptParams& p) const;
  int updates() const { return updates_; }
  double hueOffsetDeg() const { return hue_offset_deg_; }

 private:
  int updates_ = 0;
  double last_s_ = -1e300;
  double hue_offset_deg_ = 0, hue_sigma_deg_ = 0;
  RegionColour last_;
};

// The centre of a class's hue window (degrees, 0..360; min > max wraps through 0) and its half
// width.
double hueWindowCentreDeg(double hue_min_deg, double hue_max_deg);
double hueWindowHalfwidthDeg(double hue_min_deg, double hue_max_deg);
// a - b wrapped to (-180, 180].
double hueDifferenceDeg(double a_deg, double b_deg);

// Whether pixels' hues (as 8-bit levels, levels_per_deg to a degree) are two groups, two objects
// of near hues rather than one: split at Otsu's threshold, each side at least min_pixels, their
// means kMinGapDeg and kMinSeparation pooled deviations apart, and the histogram between the means
// dipping below kMaxValleyFraction of the smaller side's peak (an even spread, one shaded object,
// has no such valley). The upper group is the levels above `threshold`.
struct HueGroups {
  static constexpr double kMinGapDeg = 5;
  static constexpr double kMinSeparation = 4;
  static constexpr double kMaxValleyFraction = 0.5;
  bool two = false;
  double threshold = 0;
  double gap_deg = 0, pooled_sigma_deg = 0, valley_fraction = 1;
};
HueGroups twoHueGroups(const std::vector<uint8_t>& levels, double levels_per_deg,
                       double min_pixels);

}  // namespace ptz::perception
