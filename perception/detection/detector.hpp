// 2D detection, the paper's chain for one image: a 3x3 filter, RGB -> HSI colour segmentation,
// morphological clean-up, contours by border following, invariant Hu moments matched against
// the class's template shape, centroid (centre of gravity), area and bounding box.
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <utility>
#include <vector>

#include "common/config.hpp"
#include "perception/detection/color_model.hpp"

namespace ptz::perception {

struct ColorClass {
  std::string name;
  // Hue window in degrees (0..360); min > max wraps through 0 (red: 340..20).
  double hue_min_deg = 0, hue_max_deg = 360;
  // HSI saturation 1 - min(R,G,B)/I, 0..1.
  double saturation_min = 0.4, saturation_max = 1.0;
  // HSI intensity (R+G+B)/3, 0..255.
  double intensity_min = 20, intensity_max = 255;
  // Template shape: "circle", "square" or "any".
  std::string shape = "circle";
  // Largest accepted relative distance of the region's shape invariant from the template's.
  double max_shape_distance = 0.025;
  // Largest accepted elongation (0 round or square, 1 a line); a sphere seen off-axis is an
  // ellipse, so "circle" accepts ellipses up to this.
  double max_elongation = 0.5;
  double min_area_px2 = 30;
  double max_area_px2 = 200000;
};

struct DetectorParams {
  static constexpr size_t kMaxClasses = 8;  // a bit each in the label image
  int filter_size_px = 3;                   // median filter (the paper's 3x3 mask)
  int morph_size_px = 3;                    // opening then closing
  std::vector<ColorClass> classes;
  ColorAdaptParams adapt;  // relative intensity, the hue model

  // Reads the config section `classes` (a list of maps with the fields of ColorClass).
  static DetectorParams fromConfig(const cv::FileNode& classes, const std::string& where);
};

// Throws ConfigError naming its source when parameter `target_class` is none of dp's classes.
void checkTargetClass(const Params& p, const DetectorParams& dp);

struct Region {
  int class_index = -1;
  cv::Point2d centroid_px;  // centre of gravity of the region (distorted image coordinates)
  double area_px2 = 0;
  cv::Rect bbox;
  double shape_distance = 0;
  double elongation = 0;
  // A disc split from a blob of overlapping balls (disc_split.hpp): the blob's box, shared by
  // the discs of one blob of its class (empty: a region of its own), and the share of the disc's
  // circumference seen. Its centroid is the circle's centre, its area the whole disc's.
  cv::Rect blob_bbox;
  double arc_fraction = 1;
  bool split() const { return !blob_bbox.empty(); }
  // Whether both are discs of one blob.
  bool siblingOf(const Region& o) const {
    return split() && o.class_index == class_index && o.blob_bbox == blob_bbox;
  }
  // Its colour (a whole region's; not measured for a split disc).
  RegionColour colour;
};

// From Hu's first two invariants phi1, phi2: the shape invariant sqrt(phi1^2 - phi2) / 2, which
// is the same for every ellipse (1 / 4 pi), so a sphere matches a circle however perspective
// stretches it, while a square (1/12) is 4.7 % away; and the elongation sqrt(phi2) / phi1
// ((a/b - b/a) / (a/b + b/a) for an ellipse of axes a, b). The higher Hu moments of blobs of a
// few hundred pixels are noise.
struct ShapeScore {
  double distance = 0;  // relative difference of the shape invariants
  double elongation = 0;
};
ShapeScore huShape(const cv::Moments& shape, const cv::Moments& templ);

class Detector {
 public:
  explicit Detector(DetectorParams params);

  // Regions of every class in an 8-bit BGR image, largest first within a class.
  std::vector<Region> detect(const cv::Mat& bgr) const;
  // The same on a part of an image whose top-left pixel is `offset` in the full image: regions in
  // full-image coordinates (the part is filtered as an image of its own, see exactMarginPx).
  std::vector<Region> detect(const cv::Mat& part, const cv::Point& offset) const;
  // How far the filters reach (median, opening, closing): a part's pixels this far from its edges
  // (but for edges on the image's) are those of a full scan.
  int exactMarginPx() const;
  // Regions of `window` (full-image coordinates) from `crop`, the pixels of the full image (of
  // size image) from crop_origin, holding the window and exactMarginPx around it (or up to the
  // image's edge): exactly a full scan's regions that lie inside the window, not touching its
  // edge (but where that is the image's). *cut: a region crosses the window's edge (it may go on
  // outside; its pixels are not a full scan's).
  std::vector<Region> detectWindow(const cv::Mat& crop, const cv::Point& crop_origin,
                                   const cv::Rect& window, const cv::Size& image, bool* cut) const;
  // Candidates in an image reduced by `scale` (a pyramid full scan's level; coordinates are the
  // reduced image's): the same filters, the area limits divided by scale^2 and widened by
  // kReducedAreaSlack (a small region's area shrinks more than by scale^2: its edge pixels mix
  // with the background), no shape test (judged at full resolution in the candidate's window).
  std::vector<Region> detectReduced(const cv::Mat& reduced_bgr, int scale) const;
  static constexpr double kReducedAreaSlack = 2;
  // Whether a BGR colour falls in a class's HSI window (the definition the table is built from).
  static bool inClass(const ColorClass& c, uchar b, uchar g, uchar r);
  // The segmentation mask of class `index` in a (filtered) BGR image, after clean-up.
  cv::Mat mask(const cv::Mat& bgr, size_t index) const;
  const DetectorParams& params() const { return params_; }
  // The classes' hue gates (by class index; from their ColorModel), set between frames: a scan
  // reads them, on both cores.
  void setGates(std::vector<HueGate> gates) { gates_ = std::move(gates); }

 private:
  void label(const cv::Mat& bgr, cv::Mat* labels) const;
  // The adaptive classes' pixels kept (ColorAdaptParams): the relative intensity limit of the
  // scanned part, the hue gates.
  void adaptLabels(const cv::Mat& bgr, cv::Mat* labels) const;
  // The colour of a region's pixels (mask: its pixels in bgr).
  RegionColour measureColour(const cv::Mat& bgr, const cv::Mat& mask, size_t class_index) const;
  double hueDegOf(uchar b, uchar g, uchar r) const;
  // A pixel's hue from its class's window centre, wrapped to (-180, 180].
  double hueOffsetDeg(uchar b, uchar g, uchar r, size_t class_index) const;
  // A level's tests: the classes' area limits times these factors, the shape test or none.
  struct Limits {
    double min_area_factor = 1, max_area_factor = 1;
    bool shape = true;
  };
  // detect() at offset; with a window, only regions inside *interior, *cut when one crosses it.
  std::vector<Region> detectIn(const cv::Mat& bgr, const cv::Point& offset, const cv::Rect* window,
                               const cv::Rect* interior, bool* cut, const Limits& limits) const;
  // The class's mask; *roi: the part of it that holds the class's pixels (empty: none).
  cv::Mat maskFromLabels(const cv::Mat& labels, size_t index, cv::Rect* roi) const;
  // The region of class ci of one outer contour (in the scanned part) of `mask` (whose top-left
  // pixel is mask_origin in the part): *alone, mask's pixels inside the contour in its box, and
  // their moments. False when their area is outside the class's limits.
  bool contourRegion(const std::vector<cv::Point>& contour, const cv::Mat& mask,
                     const cv::Point& mask_origin, size_t ci, const cv::Point& offset,
                     const Limits& limits, Region* r, cv::Mat* alone, cv::Moments* mo) const;
  // The shape test of class ci on a region's moments; sets its shape distance and elongation.
  bool shapeOk(const cv::Moments& mo, size_t ci, Region* r) const;
  // The colour of a region's pixels of its class (alone: its pixels in bbox, in the part).
  RegionColour colourOf(const cv::Mat& filtered, const cv::Mat& labels, const cv::Mat& alone,
                        const cv::Rect& bbox, size_t ci) const;
  // A blob of class ci (blob: its pixels in bbox) that failed the shape test, split at Otsu's
  // threshold (OpenCV's) of its pixels' hues when they make two groups (twoHueGroups): the
  // regions of each side that pass the area and shape tests. A ball before a poster of a near hue
  // inside the class's window, found before the colour model has learnt its hue (a gate then
  // keeps it apart).
  std::vector<Region> splitByHue(const cv::Mat& filtered, const cv::Mat& labels,
                                 const cv::Mat& blob, const cv::Rect& bbox, size_t ci,
                                 const cv::Point& offset, const Limits& limits) const;
  static constexpr int kMaxHueSplitBoxPerPixel = 4;

  DetectorParams params_;
  std::vector<cv::Moments> templates_;
  cv::Mat kernel_;
  // RGB -> HSI segmentation of every 24-bit colour, computed once: bit k set when the colour is
  // in class k (up to 8 classes). Exact, and one lookup per pixel instead of a conversion.
  std::vector<uint8_t> class_table_;
  // Hue in tenths of a degree by (g - b, 2r - g - b), for the adaptive classes' pixels.
  std::vector<uint16_t> hue_tenths_;
  uint8_t relative_bits_ = 0;            // classes with a relative intensity limit
  double hue_noise_deg_per_chroma_ = 0;  // the hue gate's widening times a pixel's chroma
  std::vector<double> hue_centre_deg_;
  std::vector<HueGate> gates_;
};

}  // namespace ptz::perception
