#include "perception/markers/marker_detector.hpp"

#include <apriltag.h>
#include <tag16h5.h>
#include <tag25h9.h>
#include <tag36h11.h>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "common/config.hpp"
#include "common/markers.hpp"

namespace ptz::perception {

cv::Rect MarkerSighting::bbox() const {
  double x0 = corners_px[0].x, x1 = x0, y0 = corners_px[0].y, y1 = y0;
  for (const auto& c : corners_px) {
    x0 = std::min(x0, c.x), x1 = std::max(x1, c.x);
    y0 = std::min(y0, c.y), y1 = std::max(y1, c.y);
  }
  const int l = static_cast<int>(std::floor(x0)), t = static_cast<int>(std::floor(y0));
  return {l, t, static_cast<int>(std::ceil(x1)) - l + 1, static_cast<int>(std::ceil(y1)) - t + 1};
}

struct MarkerDetector::AprilTag {
  std::string family;
  apriltag_family_t* tag_family = nullptr;
  void (*destroy_family)(apriltag_family_t*) = nullptr;
  apriltag_detector_t* detector = nullptr;
  ~AprilTag() {
    if (detector) apriltag_detector_destroy(detector);
    if (tag_family) destroy_family(tag_family);
  }
};

struct MarkerDetector::Aruco {
  std::string family;
  cv::Ptr<cv::aruco::Dictionary> dictionary;
  cv::Ptr<cv::aruco::DetectorParameters> params;
};

MarkerDetector::MarkerDetector(std::vector<MarkerClass> classes, MarkerDetectorParams params)
    : classes_(std::move(classes)), params_(params) {
  for (const auto& c : classes_) {
    if (c.detector == "apriltag") {
      bool have = false;
      for (const auto& a : apriltags_) have = have || a->family == c.family;
      if (have) continue;
      auto a = std::make_unique<AprilTag>();
      a->family = c.family;
      if (c.family == "apriltag_36h11") {
        a->tag_family = tag36h11_create(), a->destroy_family = tag36h11_destroy;
      } else if (c.family == "apriltag_25h9") {
        a->tag_family = tag25h9_create(), a->destroy_family = tag25h9_destroy;
      } else if (c.family == "apriltag_16h5") {
        a->tag_family = tag16h5_create(), a->destroy_family = tag16h5_destroy;
      } else {
        throw ConfigError("marker class '" + c.name + "': libapriltag has no family " + c.family);
      }
      a->detector = apriltag_detector_create();
      // Corrections beyond max_hamming are refused anyway: do not pay for their tables.
      apriltag_detector_add_family_bits(a->detector, a->tag_family, params_.max_hamming);
      a->detector->quad_decimate = static_cast<float>(params_.apriltag_decimate);
      a->detector->nthreads = params_.apriltag_threads;
      a->detector->refine_edges = true;
      apriltags_.push_back(std::move(a));
    } else {
      bool have = false;
      for (const auto& a : arucos_) have = have || a->family == c.family;
      if (have) continue;
      auto a = std::make_unique<Aruco>();
      a->family = c.family;
      a->dictionary = cv::aruco::getPredefinedDictionary(markerFamilyDictionary(c.family));
      a->params = cv::aruco::DetectorParameters::create();
      a->params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_APRILTAG;
      arucos_.push_back(std::move(a));
    }
  }
}

MarkerDetector::~MarkerDetector() = default;

std::vector<MarkerSighting> MarkerDetector::detect(const cv::Mat& image, const cv::Point& offset,
                                                   int* unclaimed, double decimate,
                                                   int only_class) {
  std::vector<MarkerSighting> out;
  if (image.empty()) return out;
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else {
    grey = image.isContinuous() ? image : image.clone();
  }
  // The class that takes id of family (-1: none).
  auto classOf = [&](const std::string& family, const std::string& detector, int id) {
    for (size_t i = 0; i < classes_.size(); ++i) {
      const MarkerClass& c = classes_[i];
      if (c.family == family && c.detector == detector && !c.objectName(id).empty()) {
        return static_cast<int>(i);
      }
    }
    return -1;
  };
  auto add = [&](int class_index, int id, const std::array<cv::Point2d, 4>& corners, double margin,
                 int hamming) {
    if (class_index < 0) {
      if (unclaimed) ++*unclaimed;
      return;
    }
    for (int k = 0; k < 4; ++k) {
      if (cv::norm(corners[static_cast<size_t>(k)] - corners[static_cast<size_t>((k + 1) % 4)]) <
          params_.min_edge_px) {
        ++refused_small_;
        return;
      }
    }
    MarkerSighting s;
    s.class_index = class_index;
    s.id = id;
    s.decision_margin = margin;
    s.hamming = hamming;
    for (size_t k = 0; k < 4; ++k) s.corners_px[k] = corners[k] + cv::Point2d(offset);
    // Diagonals 0-2 and 1-3 intersect at the tag's centre (a homography keeps lines).
    const cv::Point2d a = s.corners_px[0], b = s.corners_px[2], c = s.corners_px[1],
                      d = s.corners_px[3];
    const cv::Point2d r = b - a, q = d - c;
    const double den = r.x * q.y - r.y * q.x;
    s.centre_px = std::abs(den) > 1e-9 ? a + r * (((c - a).x * q.y - (c - a).y * q.x) / den)
                                       : (a + b + c + d) * 0.25;
    out.push_back(s);
  };
  // libapriltag 3.3 crashes on an image that is, once decimated, under 3 rows (its clustering
  // reads tasks it never set: SIGSEGV) or under a column (a modulo by zero: SIGFPE): a window cut
  // to a sliver at the frame's edge (fuzz_markers). Such a part is searched at full resolution,
  // and one under 3 rows not at all (no tag fits in it).
  double quad_decimate = decimate > 0 ? decimate : params_.apriltag_decimate;
  if (grey.rows < 4 * quad_decimate || grey.cols < 4 * quad_decimate) quad_decimate = 1;
  // Whether a family's detector runs in this call.
  const auto wanted = [&](const std::string& family, const char* detector) {
    if (only_class < 0 || static_cast<size_t>(only_class) >= classes_.size()) return true;
    const MarkerClass& c = classes_[static_cast<size_t>(only_class)];
    return c.family == family && c.detector == detector;
  };
  for (const auto& a : apriltags_) {
    if (!wanted(a->family, "apriltag")) continue;
    if (grey.rows < 3) break;
    a->detector->quad_decimate = static_cast<float>(quad_decimate);
    image_u8_t im{grey.cols, grey.rows, static_cast<int32_t>(grey.step[0]), grey.data};
    zarray_t* found = apriltag_detector_detect(a->detector, &im);
    for (int i = 0; i < zarray_size(found); ++i) {
      apriltag_detection_t* det = nullptr;
      zarray_get(found, i, &det);
      if (det->hamming > params_.max_hamming) {
        ++refused_hamming_;
        continue;
      }
      if (det->decision_margin < params_.min_decision_margin) {
        ++refused_margin_;
        continue;
      }
      // libapriltag's corners go bottom-left, bottom-right, top-right, top-left (its tag frame's
      // (-1, 1), (1, 1), (1, -1), (-1, -1) with y down).
      std::array<cv::Point2d, 4> corners;
      // Its pixel centres are at +0.5 (a pixel covers [x, x + 1)); OpenCV's at the integers.
      for (size_t k = 0; k < 4; ++k) corners[k] = {det->p[3 - k][0] - 0.5, det->p[3 - k][1] - 0.5};
      add(classOf(a->family, "apriltag", det->id), det->id, corners, det->decision_margin,
          det->hamming);
    }
    apriltag_detections_destroy(found);
  }
  // ArUco costs 6-8 times libapriltag on a textured image: where a decimation is asked for (a
  // band's search for new tags; a tracked tag's window is at full resolution) it reads the part
  // reduced by it, and its corners are scaled back.
  const double aruco_scale = decimate > 1 ? decimate : 1;
  cv::Mat aruco_grey = grey;
  const bool any_aruco = std::any_of(arucos_.begin(), arucos_.end(),
                                     [&](const auto& a) { return wanted(a->family, "aruco"); });
  if (aruco_scale > 1 && any_aruco) {
    // A part too small for a tag once reduced is not read (nor reduced to nothing: resize throws).
    if (cvRound(grey.cols / aruco_scale) < 8 || cvRound(grey.rows / aruco_scale) < 8) {
      aruco_grey = cv::Mat();
    } else {
      cv::resize(grey, aruco_grey, cv::Size(), 1 / aruco_scale, 1 / aruco_scale, cv::INTER_AREA);
    }
  }
  for (const auto& a : arucos_) {
    if (aruco_grey.cols < 8 || aruco_grey.rows < 8) break;  // no tag of min_edge_px fits
    if (!wanted(a->family, "aruco")) continue;
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(aruco_grey, a->dictionary, corners, ids, a->params);
    for (size_t i = 0; i < ids.size(); ++i) {
      if (corners[i].size() != 4) continue;
      // ArUco's top-left of an AprilTag is the printed tag's bottom-right.
      const size_t turn = markerFamilyUpsideDownInOpenCv(a->family) ? 2 : 0;
      std::array<cv::Point2d, 4> c;
      // Its AprilTag refinement (libapriltag's, ported) keeps libapriltag's +0.5 pixel centres,
      // i.e. pixel edges at the integers: a reduced image's coordinates scale from them.
      for (size_t k = 0; k < 4; ++k) {
        c[k] = cv::Point2d(corners[i][(k + turn) % 4]) * aruco_scale - cv::Point2d(0.5, 0.5);
      }
      add(classOf(a->family, "aruco", ids[i]), ids[i], c, 0, 0);
    }
  }
  return out;
}

}  // namespace ptz::perception
