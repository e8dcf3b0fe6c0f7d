#include "perception/detect/detector.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <climits>
#include <cmath>

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
Hsi toHsi(int b, int g, int r) {
  const int sum = b + g + r;
  const int mn = std::min({b, g, r});
  Hsi h;
  h.intensity = sum / 3.0;
  h.saturation = sum > 0 ? 1.0 - 3.0 * mn / sum : 0.0;
  h.hue_deg = std::atan2(std::sqrt(3.0) * (g - b), 2.0 * r - g - b) * 180.0 / M_PI;
  if (h.hue_deg < 0) h.hue_deg += 360.0;
  return h;
}

bool inWindow(const ColorClass& c, const Hsi& h, bool grey) {
  if (h.intensity < c.intensity_min || h.intensity > c.intensity_max ||
      h.saturation < c.saturation_min || h.saturation > c.saturation_max) {
    return false;
  }
  if (grey) return c.hue_min_deg <= 0 && c.hue_max_deg >= 360;  // grey has no hue
  return c.hue_min_deg <= c.hue_max_deg
             ? (h.hue_deg >= c.hue_min_deg && h.hue_deg <= c.hue_max_deg)
             : (h.hue_deg >= c.hue_min_deg || h.hue_deg <= c.hue_max_deg);
}

}  // namespace

DetectorParams DetectorParams::fromConfig(const cv::FileNode& classes, const std::string& where) {
  DetectorParams p;
  if (classes.empty() || !classes.isSeq()) {
    throw ConfigError(where + ": field 'classes' must be a non-empty list");
  }
  int i = 0;
  for (const auto& n : classes) {
    const std::string w = where + ", classes[" + std::to_string(i++) + "]";
    ColorClass c;
    c.name = readString(n, "name", w);
    c.hue_min_deg = readDouble(n, "hue_min_deg", w);
    c.hue_max_deg = readDouble(n, "hue_max_deg", w);
    c.saturation_min = readDouble(n, "saturation_min", w, c.saturation_min);
    c.saturation_max = readDouble(n, "saturation_max", w, c.saturation_max);
    c.intensity_min = readDouble(n, "intensity_min", w, c.intensity_min);
    c.intensity_max = readDouble(n, "intensity_max", w, c.intensity_max);
    c.shape = n["shape"].empty() ? c.shape : readString(n, "shape", w);
    c.max_shape_distance = readDouble(n, "max_shape_distance", w, c.max_shape_distance);
    c.max_elongation = readDouble(n, "max_elongation", w, c.max_elongation);
    c.min_area_px2 = readDouble(n, "min_area_px2", w, c.min_area_px2);
    c.max_area_px2 = readDouble(n, "max_area_px2", w, c.max_area_px2);
    if (c.shape != "circle" && c.shape != "square" && c.shape != "any") {
      throw ConfigError(w + ": field 'shape' must be circle, square or any (got '" + c.shape +
                        "')");
    }
    for (double h : {c.hue_min_deg, c.hue_max_deg}) {
      if (h < 0 || h > 360) throw ConfigError(w + ": hue limits must be within 0..360 degrees");
    }
    if (c.saturation_min > c.saturation_max || c.intensity_min > c.intensity_max ||
        c.min_area_px2 > c.max_area_px2) {
      throw ConfigError(w + ": a minimum exceeds its maximum");
    }
    p.classes.push_back(c);
  }
  return p;
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
  if (params_.classes.size() > 8) throw ConfigError("at most 8 colour classes");
  for (const auto& c : params_.classes) templates_.push_back(templateMoments(c.shape));
  class_table_.assign(size_t{1} << 24, 0);
  cv::parallel_for_(cv::Range(0, 256), [this](const cv::Range& reds) {
    for (int r = reds.start; r < reds.end; ++r) {
      for (int g = 0; g < 256; ++g) {
        for (int b = 0; b < 256; ++b) {
          const Hsi h = toHsi(b, g, r);
          const bool grey = b == g && g == r;
          uint8_t bits = 0;
          for (size_t k = 0; k < params_.classes.size(); ++k) {
            if (inWindow(params_.classes[k], h, grey)) bits |= static_cast<uint8_t>(1u << k);
          }
          class_table_[(static_cast<size_t>(r) << 16) | (g << 8) | b] = bits;
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
  return maskFromLabels(labels, index, &roi);
}

std::vector<Region> Detector::detect(const cv::Mat& bgr) const {
  cv::Mat filtered, labels;
  cv::medianBlur(bgr, filtered, params_.filter_size_px);
  label(filtered, &labels);
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
    for (const auto& contour : contours) {
      const cv::Rect bbox = cv::boundingRect(contour);
      // Moments of the region's pixels (not of the polygon), alone in its box: the centre of
      // gravity of exactly this region.
      cv::Mat alone(bbox.size(), CV_8U, cv::Scalar(0));
      cv::drawContours(alone, std::vector<std::vector<cv::Point>>{contour}, 0, cv::Scalar(255),
                       cv::FILLED, cv::LINE_8, cv::noArray(), INT_MAX, -bbox.tl());
      const cv::Moments mo = cv::moments(alone & m(bbox), true);
      if (mo.m00 < c.min_area_px2 || mo.m00 > c.max_area_px2) continue;
      Region r;
      r.class_index = static_cast<int>(ci);
      r.area_px2 = mo.m00;
      r.centroid_px = {bbox.x + mo.m10 / mo.m00, bbox.y + mo.m01 / mo.m00};
      r.bbox = bbox;
      if (c.shape != "any") {
        const ShapeScore score = huShape(mo, templates_[ci]);
        r.shape_distance = score.distance;
        r.elongation = score.elongation;
        if (r.shape_distance > c.max_shape_distance || r.elongation > c.max_elongation) continue;
      }
      regions.push_back(r);
    }
    std::sort(regions.begin() + static_cast<ptrdiff_t>(first), regions.end(),
              [](const Region& a, const Region& b) { return a.area_px2 > b.area_px2; });
  }
  return regions;
}

}  // namespace ptz::perception
