// The colour detector (perception/detection/detector.hpp) on images painted from the input, with
// config/detect_default.yaml's classes: bytes 0-1 the size (8 .. 135 px a side), byte 2 the grey
// of the background and the noise's seed, then records of 8 bytes, each a filled rectangle (bit 0
// of its first byte clear) or disc: x, y, width, height (or radius), b, g, r. Overlapping shapes
// of near hues are the blobs the split by hue takes. The same bytes also go to twoHueGroups as
// hue levels. Properties: every region of a valid class, finite, its box inside the image, its
// area within its class's limits and (but for a split disc) its centroid in its box and its area
// within the box; a part scanned at an offset gives regions inside the part; the same image gives
// the same regions; twoHueGroups says two only with its gap, separation and valley.
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

#include "fuzz/fuzz_support.hpp"
#include "perception/detection/color_model.hpp"
#include "perception/detection/detector.hpp"

namespace {

using ptz::perception::Region;

const ptz::perception::Detector& detector() {
  static const ptz::perception::Detector d([] {
    cv::FileStorage fs(PTZ_FUZZ_DETECT_CONFIG, cv::FileStorage::READ);
    return ptz::perception::DetectorParams::fromConfig(fs["classes"], PTZ_FUZZ_DETECT_CONFIG);
  }());
  return d;
}

void checkRegions(const std::vector<Region>& regions, const cv::Rect& scanned) {
  const auto& classes = detector().params().classes;
  for (const Region& r : regions) {
    FUZZ_CHECK(r.class_index >= 0 && r.class_index < static_cast<int>(classes.size()),
               std::to_string(r.class_index));
    const auto& c = classes[static_cast<size_t>(r.class_index)];
    FUZZ_CHECK(std::isfinite(r.centroid_px.x) && std::isfinite(r.centroid_px.y) &&
                   std::isfinite(r.area_px2) && std::isfinite(r.shape_distance) &&
                   std::isfinite(r.elongation),
               "a region's numbers");
    FUZZ_CHECK((r.bbox & scanned) == r.bbox && !r.bbox.empty(), "box outside the scanned part");
    FUZZ_CHECK(r.area_px2 >= c.min_area_px2 && r.area_px2 <= c.max_area_px2,
               std::to_string(r.area_px2));
    if (r.split()) continue;  // a disc: its circle's centre and area
    FUZZ_CHECK(r.centroid_px.x >= r.bbox.x && r.centroid_px.x <= r.bbox.br().x &&
                   r.centroid_px.y >= r.bbox.y && r.centroid_px.y <= r.bbox.br().y,
               "centroid outside its box");
    FUZZ_CHECK(r.area_px2 <= r.bbox.area(), "more pixels than its box");
    FUZZ_CHECK(r.colour.pixels <= r.area_px2 && std::isfinite(r.colour.hue_offset_deg) &&
                   std::abs(r.colour.hue_offset_deg) <= 180 &&
                   std::isfinite(r.colour.hue_sigma_deg),
               "its colour");
  }
}

bool sameRegions(const std::vector<Region>& a, const std::vector<Region>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].class_index != b[i].class_index || a[i].centroid_px != b[i].centroid_px ||
        a[i].area_px2 != b[i].area_px2 || a[i].bbox != b[i].bbox) {
      return false;
    }
  }
  return true;
}

void checkHueGroups(const uint8_t* data, size_t size) {
  const std::vector<uint8_t> levels(data, data + size);
  const double per_deg = 255.0 / (1 + data[0] % 120);
  const ptz::perception::HueGroups g = ptz::perception::twoHueGroups(levels, per_deg, data[1]);
  using G = ptz::perception::HueGroups;
  FUZZ_CHECK(g.threshold >= 0 && g.threshold <= 255, std::to_string(g.threshold));
  FUZZ_CHECK(std::isfinite(g.gap_deg) && std::isfinite(g.pooled_sigma_deg) &&
                 std::isfinite(g.valley_fraction) && g.valley_fraction >= 0,
             "its numbers");
  if (g.two) {
    FUZZ_CHECK(g.gap_deg >= G::kMinGapDeg && g.gap_deg >= G::kMinSeparation * g.pooled_sigma_deg &&
                   g.valley_fraction <= G::kMaxValleyFraction,
               "two groups without their gap, separation or valley");
  }
}

}  // namespace

// The detector's table of every 24-bit colour takes seconds under the sanitizers: built before the
// first input, as ptz-detect builds it before the first frame.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  detector();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 3) return 0;
  checkHueGroups(data, size);
  const int width = 8 + data[0] % 128, height = 8 + data[1] % 128;
  cv::Mat img(height, width, CV_8UC3, cv::Scalar::all(data[2]));
  for (size_t at = 3; at + 8 <= size && at < 3 + 8 * 16; at += 8) {
    const uint8_t* p = data + at;
    const cv::Scalar bgr(p[5], p[6], p[7]);
    const cv::Point corner(p[1] % width, p[2] % height);
    if (p[0] & 1) {
      cv::circle(img, corner, 1 + p[3] % 64, bgr, cv::FILLED, cv::LINE_AA);
    } else {
      cv::rectangle(img, cv::Rect(corner, cv::Size(1 + p[3] % 128, 1 + p[4] % 128)), bgr,
                    cv::FILLED);
    }
  }
  cv::Mat noise(img.size(), CV_8UC3);
  cv::RNG rng(data[2]);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 4);
  img += noise;

  const cv::Rect whole(0, 0, width, height);
  const std::vector<Region> regions = detector().detect(img);
  checkRegions(regions, whole);
  FUZZ_CHECK(sameRegions(regions, detector().detect(img.clone())), "the same image, other regions");
  // A part from (x0, y0) as ptz-detect scans one at its offset.
  const int x0 = data[0] % (width / 2 + 1), y0 = data[1] % (height / 2 + 1);
  const cv::Rect part(x0, y0, width - x0, height - y0);
  checkRegions(detector().detect(img(part).clone(), part.tl()), part);
  return 0;
}
