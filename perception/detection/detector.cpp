#include "perception/detection/detector.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>

#include "perception/detection/disc_split.hpp"

namespace ptz::perception {
namespace {

cv::Moments templateMoments(const std::string& shape) {
  cv::Mat img(200, 200, CV_8U, cv::Scalar(0));
  if (shape == "circle") {
    cv::circle(img, {100, 100}, 80, cv::Scalar(255), cv::FILLED, cv::LINE_8);
  } else if (shape == "square") {
    cv::rectangle(img, {30, 30}, {170, 170}, cv::Scalar(255), cv::FILLED);
  }
  return cv::moments(img, true);
}

struct Hsi {
  double hue_deg, saturation, intensity;
};

// RGB -> HSI. The hue angle atan2(sqrt(3) (G - B), 2R - G - B) is the HSI model's
// arccos((R - G + R - B) / 2 / sqrt((R - G)^2 + (R - B)(G - B))), without the square root.
// Each part of HSI depends on one pair of integers: the hue on g - b and 2r - g - b, saturation
// and intensity on min and sum (the colour table is built from these pairs).
double hueDeg(int g_minus_b, int two_r_minus_g_minus_b) {
  const double h =
      std::atan2(std::sqrt(3.0) * g_minus_b, static_cast<double>(two_r_minus_g_minus_b)) * 180.0 /
      M_PI;
  return h < 0 ? h + 360.0 : h;
}
double saturationOf(int mn, int sum) {
  return sum > 0 ? 1.0 - 3.0 * mn / sum : 0.0;
}
double intensityOf(int sum) {
  return sum / 3.0;
}
Hsi toHsi(int b, int g, int r) {
  const int sum = b + g + r;
  return {hueDeg(g - b, 2 * r - g - b), saturationOf(std::min({b, g, r}), sum), intensityOf(sum)};
}

bool inLevels(const ColorClass& c, double saturation, double intensity) {
  return !(intensity < c.intensity_min || intensity > c.intensity_max ||
           saturation < c.saturation_min || saturation > c.saturation_max);
}
bool greyInClass(const ColorClass& c) {
  return c.hue_min_deg <= 0 && c.hue_max_deg >= 360;
}
bool inHue(const ColorClass& c, double hue_deg) {
  return c.hue_min_deg <= c.hue_max_deg ? (hue_deg >= c.hue_min_deg && hue_deg <= c.hue_max_deg)
                                        : (hue_deg >= c.hue_min_deg || hue_deg <= c.hue_max_deg);
}
bool inWindow(const ColorClass& c, const Hsi& h, bool grey) {
  if (!inLevels(c, h.saturation, h.intensity)) return false;
  return grey ? greyInClass(c) : inHue(c, h.hue_deg);  // grey has no hue
}

// A region one disc explains this much of is that ball alone (its own edge's noise aside).
constexpr double kOneBallCovered = 0.95;
constexpr int kMaxSplitsPerScan = 16;

// The discs of a blob of one or more balls, as regions of their own (see Region::split).
std::vector<Region> splitBlob(const std::vector<cv::Point>& contour, const cv::Mat& alone,
                              const Region& blob, const ColorClass& c, double* covered) {
  std::vector<Region> regions;
  // The contour is in the scanned part's coordinates, the blob's box (and `alone`) in the image's.
  const cv::Point shift = blob.bbox.tl() - cv::boundingRect(contour).tl();
  std::vector<cv::Point> in_image(contour);
  for (auto& p : in_image) p += shift;
  const double min_radius_px = std::sqrt(c.min_area_px2 / M_PI);
  for (const Disc& d : splitDiscs(in_image, alone, blob.bbox.tl(), min_radius_px, {}, covered)) {
    Region r = blob;
    r.centroid_px = d.centre_px;
    r.area_px2 = M_PI * d.radius_px * d.radius_px;
    // A disc out of the class's sizes: the blob is not what the discs say it is.
    if (r.area_px2 < c.min_area_px2 || r.area_px2 > c.max_area_px2) return {};
    const int x0 = static_cast<int>(std::floor(d.centre_px.x - d.radius_px));
    const int y0 = static_cast<int>(std::floor(d.centre_px.y - d.radius_px));
    const int x1 = static_cast<int>(std::ceil(d.centre_px.x + d.radius_px));
    const int y1 = static_cast<int>(std::ceil(d.centre_px.y + d.radius_px));
    r.bbox = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1) & blob.bbox;
    r.shape_distance = 0;
    r.elongation = 0;
    r.blob_bbox = blob.bbox;
    r.arc_fraction = d.arc_fraction;
    regions.push_back(r);
  }
  return regions;
}

}  // namespace

DetectorParams DetectorParams::fromConfig(const cv::FileNode& classes, const std::string& where) {
  DetectorParams p;
  if (classes.empty() || !classes.isSeq() || classes.size() == 0) {
    throw ConfigError(where + ", classes: must be a non-empty list");
  }
  if (classes.size() > kMaxClasses) {
    throw ConfigError(where + ", classes: at most " + std::to_string(kMaxClasses) +
                      " colour classes, got " + std::to_string(classes.size()));
  }
  int i = 0;
  for (const auto& n : classes) {
    const std::string w = where + ", classes[" + std::to_string(i++) + "]";
    checkFields(n,
                {"name", "hue_min_deg", "hue_max_deg", "saturation_min", "saturation_max",
                 "intensity_min", "intensity_max", "shape", "max_shape_distance", "max_elongation",
                 "min_area_px2", "max_area_px2"},
                w);
    ColorClass c;
    c.name = readString(n, "name", w);
    for (const auto& other : p.classes) {
      if (other.name == c.name) {
        throw ConfigError(fieldPath(w, "name") + ": a second class named '" + c.name + "'");
      }
    }
    const Range hue = Range::between(0, 360), unit = Range::between(0, 1);
    c.hue_min_deg = readDouble(n, "hue_min_deg", w, hue);
    c.hue_max_deg = readDouble(n, "hue_max_deg", w, hue);
    c.saturation_min = readDouble(n, "saturation_min", w, c.saturation_min, unit);
    c.saturation_max = readDouble(n, "saturation_max", w, c.saturation_max, unit);
    c.intensity_min = readDouble(n, "intensity_min", w, c.intensity_min, Range::between(0, 255));
    c.intensity_max = readDouble(n, "intensity_max", w, c.intensity_max, Range::between(0, 255));
    c.shape = n["shape"].empty() ? c.shape : readString(n, "shape", w);
    c.max_shape_distance =
        readDouble(n, "max_shape_distance", w, c.max_shape_distance, Range::atLeast(0));
    c.max_elongation = readDouble(n, "max_elongation", w, c.max_elongation, unit);
    c.min_area_px2 = readDouble(n, "min_area_px2", w, c.min_area_px2, Range::atLeast(0));
    c.max_area_px2 = readDouble(n, "max_area_px2", w, c.max_area_px2, Range::atLeast(0));
    if (c.shape != "circle" && c.shape != "square" && c.shape != "any") {
      throw ConfigError(fieldPath(w, "shape") + ": must be circle, square or any, got '" + c.shape +
                        "'");
    }
    checkFieldOrder(c.saturation_min, c.saturation_max, w, "saturation_min", "saturation_max",
                    false);
    checkFieldOrder(c.intensity_min, c.intensity_max, w, "intensity_min", "intensity_max", false);
    checkFieldOrder(c.min_area_px2, c.max_area_px2, w, "min_area_px2", "max_area_px2", false);
    p.classes.push_back(c);
  }
  return p;
}

void checkTargetClass(const Params& p, const DetectorParams& dp) {
  const std::string target = p.getString("target_class");
  std::string names;
  for (const auto& c : dp.classes) {
    if (c.name == target) return;
    names += (names.empty() ? "" : ", ") + c.name;
  }
  throw p.invalid("target_class", "must be one of the classes of config file '" + p.configPath() +
                                      "' (" + names + ")");
}

ShapeScore huShape(const cv::Moments& shape, const cv::Moments& templ) {
  double a[7], b[7];
  cv::HuMoments(shape, a);
  cv::HuMoments(templ, b);
  const double ia = std::sqrt(std::max(0.0, a[0] * a[0] - a[1])) / 2;
  const double ib = std::sqrt(std::max(0.0, b[0] * b[0] - b[1])) / 2;
  return {std::abs(ia - ib) / ib, a[0] > 0 ? std::sqrt(a[1]) / a[0] : 1.0};
}

Detector::Detector(DetectorParams params)
    : params_(std::move(params)),
      kernel_(cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                        {params_.morph_size_px, params_.morph_size_px})) {
  if (params_.classes.size() > DetectorParams::kMaxClasses) {
    throw ConfigError("at most " + std::to_string(DetectorParams::kMaxClasses) + " colour classes");
  }
  for (const auto& c : params_.classes) {
    templates_.push_back(templateMoments(c.shape));
    hue_centre_deg_.push_back(hueWindowCentreDeg(c.hue_min_deg, c.hue_max_deg));
  }
  const ColorAdaptParams& adapt = params_.adapt;
  hue_tenths_.assign(size_t{511} * 1021, 0);
  hue_noise_deg_per_chroma_ =
      adapt.follow_sigmas * std::sqrt(1.5) * adapt.follow_noise_grey * 180 / M_PI;
  // The class bits of every hue pair and every (min, sum) pair once, then one AND per colour:
  // the same table as inWindow on toHsi of each colour, in ~0.1 s instead of ~1.5 s, so that a
  // restarted ptz-detect is back within a frame or two.
  constexpr int kHueCols = 1021;  // 2r - g - b: -510..510; g - b: -255..255
  constexpr int kSums = 766;      // r + g + b: 0..765
  std::vector<uint8_t> hue_bits(size_t{511} * kHueCols, 0), level_bits(size_t{256} * kSums, 0);
  uint8_t grey_bits = 0;
  for (size_t k = 0; k < params_.classes.size(); ++k) {
    ColorClass c = params_.classes[k];
    const auto bit = static_cast<uint8_t>(1u << k);
    if (greyInClass(c)) grey_bits |= bit;
    // A relative limit is applied per scanned part (adaptLabels); the table keeps the floor.
    if (adapt.intensity_min_fraction > 0 && !greyInClass(c)) {
      c.intensity_min = std::min(c.intensity_min, adapt.intensity_floor);
      relative_bits_ |= bit;
    }
    for (int mn = 0; mn < 256; ++mn) {
      for (int sum = 3 * mn; sum < kSums; ++sum) {
        if (inLevels(c, saturationOf(mn, sum), intensityOf(sum)))
          level_bits[mn * kSums + sum] |= bit;
      }
    }
  }
  for (int gb = -255; gb <= 255; ++gb) {
    for (int rgb = -510; rgb <= 510; ++rgb) {
      const double h = hueDeg(gb, rgb);
      uint8_t bits = 0;
      for (size_t k = 0; k < params_.classes.size(); ++k) {
        if (inHue(params_.classes[k], h)) bits |= static_cast<uint8_t>(1u << k);
      }
      hue_bits[(gb + 255) * kHueCols + rgb + 510] = bits;
      hue_tenths_[(gb + 255) * kHueCols + rgb + 510] =
          static_cast<uint16_t>(std::lround(h * 10) % 3600);
    }
  }
  class_table_.assign(size_t{1} << 24, 0);
  cv::parallel_for_(cv::Range(0, 256), [&](const cv::Range& reds) {
    for (int r = reds.start; r < reds.end; ++r) {
      for (int g = 0; g < 256; ++g) {
        for (int b = 0; b < 256; ++b) {
          const uint8_t level = level_bits[std::min({b, g, r}) * kSums + b + g + r];
          const bool grey = b == g && g == r;
          class_table_[(static_cast<size_t>(r) << 16) | (g << 8) | b] =
              grey ? level & grey_bits
                   : level & hue_bits[(g - b + 255) * kHueCols + 2 * r - g - b + 510];
        }
      }
    }
  });
}

bool Detector::inClass(const ColorClass& c, uchar b, uchar g, uchar r) {
  return inWindow(c, toHsi(b, g, r), b == g && g == r);
}

void Detector::label(const cv::Mat& bgr, cv::Mat* labels) const {
  CV_Assert(bgr.type() == CV_8UC3);
  labels->create(bgr.size(), CV_8U);
  const uint8_t* table = class_table_.data();
  for (int r = 0; r < bgr.rows; ++r) {
    const uchar* in = bgr.ptr<uchar>(r);
    uchar* out = labels->ptr<uchar>(r);
    for (int c = 0; c < bgr.cols; ++c, in += 3)
      out[c] = table[(in[2] << 16) | (in[1] << 8) | in[0]];
  }
}

double Detector::hueDegOf(uchar b, uchar g, uchar r) const {
  return 0.1 * hue_tenths_[static_cast<size_t>((g - b + 255) * 1021 + 2 * r - g - b + 510)];
}

double Detector::hueOffsetDeg(uchar b, uchar g, uchar r, size_t class_index) const {
  return hueDifferenceDeg(hueDegOf(b, g, r), hue_centre_deg_[class_index]);
}

void Detector::adaptLabels(const cv::Mat& bgr, cv::Mat* labels) const {
  const size_t n = params_.classes.size();
  uint8_t gated_bits = 0;
  for (size_t k = 0; k < std::min(n, gates_.size()); ++k) {
    if (gates_[k].active && !greyInClass(params_.classes[k])) gated_bits |= 1u << k;
  }
  const uint8_t adaptive = relative_bits_ | gated_bits;
  if (adaptive == 0) return;
  constexpr int kSums = 766;
  // The relative limits: each class's bright level, the 95th percentile of its pixels' sums.
  std::array<double, DetectorParams::kMaxClasses> min_sum{};
  if (relative_bits_ != 0) {
    // On the stack: a scan's parts are many a frame.
    std::array<std::array<int, kSums>, DetectorParams::kMaxClasses> histogram{};
    for (int y = 0; y < bgr.rows; ++y) {
      const uchar* in = bgr.ptr<uchar>(y);
      const uchar* l = labels->ptr<uchar>(y);
      for (int x = 0; x < bgr.cols; ++x) {
        const uint8_t bits = l[x] & relative_bits_;
        if (bits == 0) continue;
        const int sum = in[3 * x] + in[3 * x + 1] + in[3 * x + 2];
        for (size_t k = 0; k < n; ++k) {
          if (bits & (1u << k)) ++histogram[k][static_cast<size_t>(sum)];
        }
      }
    }
    constexpr int kMinPixels = 20;  // fewer: noise, not an object to take the light from
    for (size_t k = 0; k < n; ++k) {
      if (!(relative_bits_ & (1u << k))) continue;
      const ColorClass& c = params_.classes[k];
      const int* h = histogram[k].data();
      int total = 0;
      for (int s = 0; s < kSums; ++s) total += h[s];
      double limit = c.intensity_min;
      if (total >= kMinPixels) {
        int below = 0, s = 0;
        while (s < kSums - 1 && below + h[s] < 0.95 * total) below += h[s++];
        // Never above intensity_min, even when the floor is (a class may set intensity_min 0).
        limit = std::min(std::max(params_.adapt.intensity_min_fraction * intensityOf(s),
                                  params_.adapt.intensity_floor),
                         c.intensity_min);
      }
      min_sum[k] = 3 * limit;
    }
  }
  for (int y = 0; y < bgr.rows; ++y) {
    const uchar* in = bgr.ptr<uchar>(y);
    uchar* l = labels->ptr<uchar>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      const uint8_t bits = l[x] & adaptive;
      if (bits == 0) continue;
      const uchar b = in[3 * x], g = in[3 * x + 1], r = in[3 * x + 2];
      const int sum = b + g + r;
      const bool grey = b == g && g == r;
      double hue = 0, noise_deg = 180;
      if ((bits & gated_bits) && !grey) {
        hue = hueDegOf(b, g, r);
        // The hue's own noise at this pixel's chroma (the length of HSI's chroma vector).
        const double chroma = std::hypot(r - 0.5 * (g + b), 0.8660254 * (g - b));
        noise_deg = hue_noise_deg_per_chroma_ / chroma;
      }
      for (size_t k = 0; k < n; ++k) {
        const auto bit = static_cast<uint8_t>(1u << k);
        if (!(bits & bit)) continue;
        bool keep = !(relative_bits_ & bit) || sum >= min_sum[k];
        if (keep && (gated_bits & bit)) {
          const HueGate& gate = gates_[k];
          keep = !grey && std::abs(hueDifferenceDeg(hue, hue_centre_deg_[k] + gate.offset_deg)) <=
                              gate.halfwidth_deg + noise_deg;
        }
        if (!keep) l[x] &= static_cast<uint8_t>(~bit);
      }
    }
  }
}

RegionColour Detector::measureColour(const cv::Mat& bgr, const cv::Mat& mask,
                                     size_t class_index) const {
  // Welford's running mean and variance: a region may hold a few thousand pixels.
  RegionColour c;
  double hue_m2 = 0, sat_m2 = 0;
  int hue_n = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    const uchar* in = bgr.ptr<uchar>(y);
    const uchar* m = mask.ptr<uchar>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      if (m[x] == 0) continue;
      const uchar b = in[3 * x], g = in[3 * x + 1], r = in[3 * x + 2];
      const int sum = b + g + r;
      ++c.pixels;
      const double sat = saturationOf(std::min({b, g, r}), sum);
      const double ds = sat - c.saturation;
      c.saturation += ds / c.pixels;
      sat_m2 += ds * (sat - c.saturation);
      c.intensity += (intensityOf(sum) - c.intensity) / c.pixels;
      if (b == g && g == r) continue;
      const double off = hueOffsetDeg(b, g, r, class_index);
      ++hue_n;
      const double dh = off - c.hue_offset_deg;
      c.hue_offset_deg += dh / hue_n;
      hue_m2 += dh * (off - c.hue_offset_deg);
    }
  }
  if (c.pixels > 1) c.saturation_sigma = std::sqrt(sat_m2 / (c.pixels - 1));
  if (hue_n > 1) c.hue_sigma_deg = std::sqrt(hue_m2 / (hue_n - 1));
  return c;
}

cv::Mat Detector::maskFromLabels(const cv::Mat& labels, size_t index, cv::Rect* roi) const {
  cv::Mat m;
  cv::bitwise_and(labels, cv::Scalar(1 << index), m);
  cv::compare(m, 0, m, cv::CMP_GT);
  // Clean up only where the class has pixels: most of an image has none of a class.
  const int margin = 2 * params_.morph_size_px;
  *roi = cv::boundingRect(m);
  *roi = cv::Rect(roi->x - margin, roi->y - margin, roi->width + 2 * margin,
                  roi->height + 2 * margin) &
         cv::Rect(0, 0, m.cols, m.rows);
  if (roi->empty()) return m;
  cv::Mat part = m(*roi);
  cv::morphologyEx(part, part, cv::MORPH_OPEN, kernel_);
  cv::morphologyEx(part, part, cv::MORPH_CLOSE, kernel_);
  return m;
}

cv::Mat Detector::mask(const cv::Mat& bgr, size_t index) const {
  cv::Mat labels;
  cv::Rect roi;
  label(bgr, &labels);
  adaptLabels(bgr, &labels);
  return maskFromLabels(labels, index, &roi);
}

std::vector<Region> Detector::detect(const cv::Mat& bgr) const {
  return detect(bgr, cv::Point(0, 0));
}

int Detector::exactMarginPx() const {
  // Median, then erosion and dilation twice each (opening, closing); one more pixel so that a
  // region touching the window's edge is seen touching it.
  return params_.filter_size_px / 2 + 4 * (params_.morph_size_px / 2) + 1;
}

std::vector<Region> Detector::detectWindow(const cv::Mat& crop, const cv::Point& crop_origin,
                                           const cv::Rect& window, const cv::Size& image,
                                           bool* cut) const {
  // The window's interior: its edge rows and columns, unless they are the image's, are where a
  // region that goes on outside shows.
  const int x0 = window.x > 0 ? window.x + 1 : 0, y0 = window.y > 0 ? window.y + 1 : 0;
  const int x1 = window.br().x < image.width ? window.br().x - 1 : image.width;
  const int y1 = window.br().y < image.height ? window.br().y - 1 : image.height;
  const cv::Rect interior(x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0));
  *cut = false;
  return detectIn(crop, crop_origin, &window, &interior, cut, Limits());
}

std::vector<Region> Detector::detect(const cv::Mat& bgr, const cv::Point& offset) const {
  return detectIn(bgr, offset, nullptr, nullptr, nullptr, Limits());
}

std::vector<Region> Detector::detectReduced(const cv::Mat& reduced_bgr, int scale) const {
  const double area_per_px2 = 1.0 / (static_cast<double>(scale) * scale);
  const Limits limits{area_per_px2 / kReducedAreaSlack, area_per_px2 * kReducedAreaSlack, false};
  return detectIn(reduced_bgr, cv::Point(0, 0), nullptr, nullptr, nullptr, limits);
}

std::vector<Region> Detector::detectIn(const cv::Mat& bgr, const cv::Point& offset,
                                       const cv::Rect* window, const cv::Rect* interior, bool* cut,
                                       const Limits& limits) const {
  cv::Mat filtered, labels;
  cv::medianBlur(bgr, filtered, params_.filter_size_px);
  label(filtered, &labels);
  adaptLabels(filtered, &labels);
  std::vector<Region> regions;
  for (size_t ci = 0; ci < params_.classes.size(); ++ci) {
    const ColorClass& c = params_.classes[ci];
    cv::Rect roi;
    const cv::Mat m = maskFromLabels(labels, ci, &roi);
    if (roi.empty()) continue;
    std::vector<std::vector<cv::Point>> contours;
    // Suzuki-Abe border following (the paper's chain-code contours), outer borders only.
    cv::findContours(m(roi).clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, roi.tl());
    const size_t first = regions.size();
    int splits = 0, hue_splits = 0;
    for (const auto& contour : contours) {
      const cv::Rect bbox = cv::boundingRect(contour);
      if (window) {
        // Judged before the area and shape tests: a region cut by the window fails them.
        const cv::Rect in_image = bbox + offset;
        if ((in_image & *interior) != in_image) {
          if (!(in_image & *window).empty()) *cut = true;
          continue;
        }
      }
      Region r;
      cv::Mat alone;
      cv::Moments mo;
      if (!contourRegion(contour, m, cv::Point(0, 0), ci, offset, limits, &r, &alone, &mo)) {
        continue;
      }
      if (limits.shape && c.shape != "any") {
        const bool shape_ok = shapeOk(mo, ci, &r);
        // Balls of the class overlapping: each a disc of the blob; one ball with a sliver of
        // another behind it (which the shape test lets through) is its disc alone. Not for a
        // round blob too small to hold two balls; at most kMaxSplitsPerScan blobs a class per
        // scan (clutter of many blobs must not cost a RANSAC each).
        if (c.shape == "circle" && (!shape_ok || r.area_px2 >= 2 * c.min_area_px2) &&
            splits < kMaxSplitsPerScan) {
          ++splits;
          double covered = 1;
          std::vector<Region> discs = splitBlob(contour, alone, r, c, &covered);
          if (discs.size() >= 2 || (discs.size() == 1 && covered < kOneBallCovered)) {
            regions.insert(regions.end(), discs.begin(), discs.end());
            continue;
          }
        }
        // Two objects of the class's window but of hues apart (a ball before a poster of a near
        // hue, before any hue is learnt): each on its own. Only a blob that can hold two objects
        // and fills a quarter of its box: a scan's splits touch at most four times its pixels.
        if (!shape_ok && hue_splits < kMaxSplitsPerScan && !greyInClass(c) &&
            mo.m00 >= 2 * c.min_area_px2 * limits.min_area_factor &&
            bbox.area() <= kMaxHueSplitBoxPerPixel * mo.m00) {
          ++hue_splits;
          const std::vector<Region> parts =
              splitByHue(filtered, labels, alone, bbox, ci, offset, limits);
          regions.insert(regions.end(), parts.begin(), parts.end());
          continue;
        }
        if (!shape_ok) continue;
      }
      r.colour = colourOf(filtered, labels, alone, bbox, ci);
      regions.push_back(r);
    }
    std::sort(regions.begin() + static_cast<ptrdiff_t>(first), regions.end(),
              [](const Region& a, const Region& b) { return a.area_px2 > b.area_px2; });
  }
  return regions;
}

bool Detector::contourRegion(const std::vector<cv::Point>& contour, const cv::Mat& mask,
                             const cv::Point& mask_origin, size_t ci, const cv::Point& offset,
                             const Limits& limits, Region* r, cv::Mat* alone,
                             cv::Moments* mo) const {
  const ColorClass& c = params_.classes[ci];
  const cv::Rect bbox = cv::boundingRect(contour);
  // Moments of the region's pixels (not of the polygon), alone in its box: the centre of gravity
  // of exactly this region.
  cv::Mat filled(bbox.size(), CV_8U, cv::Scalar(0));
  cv::drawContours(filled, std::vector<std::vector<cv::Point>>{contour}, 0, cv::Scalar(255),
                   cv::FILLED, cv::LINE_8, cv::noArray(), INT_MAX, -bbox.tl());
  *alone = filled & mask(bbox - mask_origin);
  *mo = cv::moments(*alone, true);
  if (mo->m00 < c.min_area_px2 * limits.min_area_factor ||
      mo->m00 > c.max_area_px2 * limits.max_area_factor) {
    return false;
  }
  r->class_index = static_cast<int>(ci);
  r->area_px2 = mo->m00;
  // bbox.x + offset first, as an int: the same double as a full scan's.
  r->centroid_px = {(bbox.x + offset.x) + mo->m10 / mo->m00,
                    (bbox.y + offset.y) + mo->m01 / mo->m00};
  r->bbox = bbox + offset;
  return true;
}

bool Detector::shapeOk(const cv::Moments& mo, size_t ci, Region* r) const {
  const ColorClass& c = params_.classes[ci];
  const ShapeScore score = huShape(mo, templates_[ci]);
  r->shape_distance = score.distance;
  r->elongation = score.elongation;
  return r->shape_distance <= c.max_shape_distance && r->elongation <= c.max_elongation;
}

RegionColour Detector::colourOf(const cv::Mat& filtered, const cv::Mat& labels,
                                const cv::Mat& alone, const cv::Rect& bbox, size_t ci) const {
  // Its pixels of the class's colour (not those the closing filled in).
  cv::Mat coloured;
  cv::bitwise_and(labels(bbox), cv::Scalar(1 << ci), coloured);
  return measureColour(filtered(bbox), alone & (coloured > 0), ci);
}

std::vector<Region> Detector::splitByHue(const cv::Mat& filtered, const cv::Mat& labels,
                                         const cv::Mat& blob, const cv::Rect& bbox, size_t ci,
                                         const cv::Point& offset, const Limits& limits) const {
  const ColorClass& c = params_.classes[ci];
  const auto bit = static_cast<uint8_t>(1u << ci);
  // Its pixels of the class's colour: their hues' offsets from the class's hue centre, scaled to
  // 0..255 over the class's window (Otsu's threshold is OpenCV's, on 8 bits), in `levels` (-1:
  // not one of them) and in `values`, one after the other.
  const double width_deg = 2 * hueWindowHalfwidthDeg(c.hue_min_deg, c.hue_max_deg);
  if (width_deg <= 0) return {};  // one hue: no two groups of them
  const double levels_per_deg = 255 / width_deg;
  cv::Mat levels(bbox.size(), CV_16S, cv::Scalar(-1));
  std::vector<uint8_t> values;
  values.reserve(static_cast<size_t>(cv::countNonZero(blob)));
  for (int y = 0; y < bbox.height; ++y) {
    const uchar* in = filtered.ptr<uchar>(bbox.y + y) + 3 * bbox.x;
    const uchar* l = labels.ptr<uchar>(bbox.y + y) + bbox.x;
    const uchar* b = blob.ptr<uchar>(y);
    int16_t* out = levels.ptr<int16_t>(y);
    for (int x = 0; x < bbox.width; ++x) {
      const uchar bl = in[3 * x], gr = in[3 * x + 1], rd = in[3 * x + 2];
      if (!b[x] || !(l[x] & bit) || (bl == gr && gr == rd)) continue;
      const double offset_deg = hueOffsetDeg(bl, gr, rd, ci);
      const uchar level = cv::saturate_cast<uchar>((offset_deg + width_deg / 2) * levels_per_deg);
      out[x] = level;
      values.push_back(level);
    }
  }
  const HueGroups groups =
      twoHueGroups(values, levels_per_deg, c.min_area_px2 * limits.min_area_factor);
  if (!groups.two) return {};
  std::vector<Region> regions;
  for (const bool upper : {false, true}) {
    const cv::Mat hues =
        upper ? levels > groups.threshold : (levels >= 0) & (levels <= groups.threshold);
    // The class's clean-up, as its mask had: the rim's pixels of blended hues go to either side.
    cv::Mat side;
    cv::morphologyEx(hues, side, cv::MORPH_OPEN, kernel_);
    cv::morphologyEx(side, side, cv::MORPH_CLOSE, kernel_);
    side &= blob;
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(side.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, bbox.tl());
    for (const auto& contour : contours) {
      Region r;
      cv::Mat alone;
      cv::Moments mo;
      if (!contourRegion(contour, side, bbox.tl(), ci, offset, limits, &r, &alone, &mo) ||
          !shapeOk(mo, ci, &r)) {
        continue;
      }
      // Its colour from its own side's hues only (not the other's that the closing took in).
      const cv::Rect box = cv::boundingRect(contour);
      r.colour = colourOf(filtered, labels, alone & hues(box - bbox.tl()), box, ci);
      regions.push_back(r);
    }
  }
  return regions;
}

}  // namespace ptz::perception
