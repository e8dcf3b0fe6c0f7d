// Fiducial markers (perception/markers/) on images made from the input, as STEREO_FRAME's pixels
// reach them. A header of 18 bytes, then the pixels:
//   0, 1   width, height: 8 .. 160 px
//   2      bits 0-1 the class (apriltag_36h11 by libapriltag (0, 3), aruco_4x4_50 (1) or
//          apriltag_36h11 (2) by ArUco), bits 2-3 libapriltag's decimate (1, 1.5, 2, 2), bit 4
//          draw a tag, bit 5 a second one, bit 6 of the same id (else the next), bit 7 bilinear
//   3, 4   the tag's id (modulo the family's count)
//   5      the side of the tag and its white ring: 8 .. 167 px
//   6, 7   its centre, across the image and a half-tag beyond; 8 its turn (0: none)
//   9, 10  the second tag's centre from the first's (signed px)
//   11     bits 0-5 the disparity (-8 .. 55 px), bits 6-7 the right image 0-3 rows lower
//   12-15  a part of the image (its corner on even pixels, as MarkerScanner cuts them)
//   16     the tag's size (0.02 .. 1.04 m); 17 the zoom of both views (1 .. 10)
// then the grey pixels, row by row, repeated to fill (none: mid grey). The tags are
// ptz::markerCells scaled (INTER_NEAREST), turned with cv::warpAffine, so decoding and refinement
// are reached. The left and right images are two windows on one wider picture: a point `disparity`
// px further right in the left image; both are the middle of the default rig's VGA frames.
// Properties: every sighting's class, id within the family, hamming and margin within the params,
// corners and centre finite, the centre within the image (or the part) grown by 3 px and the
// corners grown by 3 px and the tag's longest edge (a tag cut by the image's edge is read, the
// corners beyond it extrapolated from its edges: libapriltag's 21 px out, edges of 55 px, 4.6 px
// from the drawn corner), a non-empty bbox; markerObjects of both views' sightings, for a class of
// single tags (any id) and for a bundle of the tags drawn: every object of a class that takes its
// sightings, its rotation orthonormal (1e-6), its position finite and within range, its covariance
// finite, symmetric and of non-negative variances, its RMS within max_rms_px; every failure one of
// the documented reasons.
#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "common/markers.hpp"
#include "common/rig.hpp"
#include "fuzz/fuzz_support.hpp"
#include "perception/markers/marker_detector.hpp"
#include "perception/markers/marker_pose.hpp"

namespace {

using ptz::perception::MarkerClass;
using ptz::perception::MarkerSighting;

constexpr size_t kHeader = 18;
// A centre may lie this far outside what was searched, a corner this far and the tag's longest
// edge (extrapolated beyond the image's edge).
constexpr double kMarginPx = 3;

struct Choice {
  const char* detector;
  const char* family;
};
constexpr Choice kChoices[4] = {{"apriltag", "apriltag_36h11"},
                                {"aruco", "aruco_4x4_50"},
                                {"aruco", "apriltag_36h11"},
                                {"apriltag", "apriltag_36h11"}};

MarkerClass singleClass(int choice, double size_m) {
  MarkerClass c;
  c.name = "tag";
  c.detector = kChoices[choice].detector;
  c.family = kChoices[choice].family;
  c.size_m = size_m;
  c.any_id = true;
  return c;
}

// One detector per class choice: libapriltag's tables are built once, as ptz-detect's are.
ptz::perception::MarkerDetector& detectorFor(int choice) {
  static std::unique_ptr<ptz::perception::MarkerDetector> detectors[4];
  if (!detectors[choice]) {
    detectors[choice] = std::make_unique<ptz::perception::MarkerDetector>(
        std::vector<MarkerClass>{singleClass(choice, 0.1)});
  }
  return *detectors[choice];
}

// Draws tag `id` of `family` with a white ring of one cell, `side` px across, centred at `centre`
// and turned by `turn_deg`, over `picture` (clipped).
void drawTag(cv::Mat& picture, const std::string& family, int id, int side, cv::Point2d centre,
             double turn_deg, bool bilinear) {
  cv::Mat cells;
  std::string why;
  FUZZ_CHECK(ptz::markerCells(family, id, &cells, &why), why);
  FUZZ_CHECK(cells.type() == CV_8UC1 && cells.rows == cells.cols && cells.rows >= 4,
             "markerCells: " + std::to_string(cells.rows) + "x" + std::to_string(cells.cols));
  cv::Mat ringed(cells.rows + 2, cells.cols + 2, CV_8UC1, cv::Scalar(255));
  cells.copyTo(ringed(cv::Rect(1, 1, cells.cols, cells.rows)));
  cv::Mat patch;
  cv::resize(ringed, patch, cv::Size(side, side), 0, 0, cv::INTER_NEAREST);
  const cv::Point2f middle((side - 1) / 2.0f, (side - 1) / 2.0f);
  cv::Mat m = cv::getRotationMatrix2D(middle, turn_deg, 1.0);
  m.at<double>(0, 2) += centre.x - middle.x;
  m.at<double>(1, 2) += centre.y - middle.y;
  cv::warpAffine(patch, picture, m, picture.size(), bilinear ? cv::INTER_LINEAR : cv::INTER_NEAREST,
                 cv::BORDER_TRANSPARENT);
}

bool finite(const cv::Point2d& p) {
  return std::isfinite(p.x) && std::isfinite(p.y);
}

std::string text(const cv::Point2d& p) {
  return "(" + std::to_string(p.x) + ", " + std::to_string(p.y) + ")";
}

// The sightings of `image` (whose top-left is `offset` in the full image) and their properties.
std::vector<MarkerSighting> detect(int choice, const cv::Mat& image, const cv::Point& offset,
                                   double decimate) {
  ptz::perception::MarkerDetector& detector = detectorFor(choice);
  int unclaimed = 0;
  const std::vector<MarkerSighting> seen = detector.detect(image, offset, &unclaimed, decimate);
  // Every id of the family is claimed (any_id).
  FUZZ_CHECK(unclaimed == 0, "unclaimed " + std::to_string(unclaimed));
  const ptz::perception::MarkerDetectorParams params;
  const int count = ptz::markerFamilyCount(kChoices[choice].family);
  const auto within = [&](const cv::Point2d& p, double margin_px) {
    return p.x >= offset.x - margin_px && p.y >= offset.y - margin_px &&
           p.x <= offset.x + image.cols + margin_px && p.y <= offset.y + image.rows + margin_px;
  };
  for (const MarkerSighting& s : seen) {
    FUZZ_CHECK(s.class_index >= 0 && static_cast<size_t>(s.class_index) < detector.classes().size(),
               "class_index " + std::to_string(s.class_index));
    FUZZ_CHECK(s.id >= 0 && s.id < count,
               "id " + std::to_string(s.id) + " of " + std::to_string(count));
    FUZZ_CHECK(s.hamming >= 0 && s.hamming <= params.max_hamming,
               "hamming " + std::to_string(s.hamming));
    if (std::string(kChoices[choice].detector) == "apriltag") {
      FUZZ_CHECK(s.decision_margin >= params.min_decision_margin,
                 "decision margin " + std::to_string(s.decision_margin));
    }
    double shortest_px = INFINITY, longest_px = 0;
    for (size_t k = 0; k < 4; ++k) {
      const cv::Point2d& c = s.corners_px[k];
      FUZZ_CHECK(finite(c), "corner " + std::to_string(k) + " " + text(c));
      const double edge_px = cv::norm(c - s.corners_px[(k + 1) % 4]);
      shortest_px = std::min(shortest_px, edge_px);
      longest_px = std::max(longest_px, edge_px);
    }
    FUZZ_CHECK(shortest_px >= params.min_edge_px,
               "an edge of " + std::to_string(shortest_px) + " px, shorter than min_edge_px");
    const std::string image_at = std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                 " at " + text(offset) + ", edges " + std::to_string(shortest_px) +
                                 ".." + std::to_string(longest_px);
    for (size_t k = 0; k < 4; ++k) {
      FUZZ_CHECK(
          within(s.corners_px[k], kMarginPx + longest_px),
          "corner " + std::to_string(k) + " " + text(s.corners_px[k]) + " outside " + image_at);
    }
    FUZZ_CHECK(finite(s.centre_px), "centre " + text(s.centre_px));
    FUZZ_CHECK(within(s.centre_px, kMarginPx),
               "centre " + text(s.centre_px) + " outside " + image_at);
    const cv::Rect box = s.bbox();
    FUZZ_CHECK(!box.empty() && box.width > 0 && box.height > 0, "empty bbox");
  }
  return seen;
}

bool orthonormal(const Eigen::Matrix3d& r) {
  return r.allFinite() &&
         (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-6 &&
         std::abs(r.determinant() - 1) <= 1e-6;
}

// markerObjects of the two views' sightings for `classes`; its properties.
void objects(const std::vector<MarkerClass>& classes, const std::vector<MarkerSighting> seen[2],
             const ptz::CameraView& left, const ptz::CameraView& right) {
  static const std::set<std::string> kReasons = {"few_corners",  "collinear",       "not_finite",
                                                 "reprojection", "corner_residual", "range",
                                                 "unobservable", "tag_seen_twice"};
  const ptz::perception::MarkerPoseParams params;
  std::vector<std::string> failed;
  const auto found =
      ptz::perception::markerObjects(classes, seen[0], seen[1], left, right, params, &failed);
  for (const std::string& f : failed) FUZZ_CHECK(kReasons.count(f) == 1, "failure '" + f + "'");
  std::set<std::string> names;
  for (const auto& o : found) {
    FUZZ_CHECK(o.class_index >= 0 && static_cast<size_t>(o.class_index) < classes.size(),
               "object class_index " + std::to_string(o.class_index));
    FUZZ_CHECK(names.insert(o.name).second, "object " + o.name + " twice");
    const MarkerClass& c = classes[static_cast<size_t>(o.class_index)];
    for (int s = 0; s < 2; ++s) {
      for (int i : o.sightings[s]) {
        FUZZ_CHECK(i >= 0 && static_cast<size_t>(i) < seen[s].size(),
                   "sighting " + std::to_string(i));
        FUZZ_CHECK(c.objectName(seen[s][static_cast<size_t>(i)].id) == o.name,
                   "a sighting not of " + o.name);
      }
    }
    const ptz::perception::MarkerPose& p = o.pose;
    FUZZ_CHECK(orthonormal(p.rotation_head_object), o.name + ": rotation not orthonormal");
    FUZZ_CHECK(p.position_head_m.allFinite(), o.name + ": position not finite");
    const double range_m = std::min((p.position_head_m - left.position_head_m).norm(),
                                    (p.position_head_m - right.position_head_m).norm());
    FUZZ_CHECK(range_m >= params.min_range_m && range_m <= params.max_range_m,
               o.name + ": range " + std::to_string(range_m));
    FUZZ_CHECK(p.covariance.allFinite(), o.name + ": covariance not finite");
    const double scale = std::max(1e-300, p.covariance.cwiseAbs().maxCoeff());
    FUZZ_CHECK((p.covariance - p.covariance.transpose()).cwiseAbs().maxCoeff() <= 1e-6 * scale,
               o.name + ": covariance not symmetric");
    FUZZ_CHECK((p.covariance.diagonal().array() >= 0).all(), o.name + ": a negative variance");
    FUZZ_CHECK(std::isfinite(p.rms_px) && p.rms_px >= 0 && p.rms_px <= params.max_rms_px,
               o.name + ": rms " + std::to_string(p.rms_px));
    FUZZ_CHECK(p.stereo_corners >= 3,
               o.name + ": " + std::to_string(p.stereo_corners) + " corners in both views");
    FUZZ_CHECK(std::isfinite(o.radius_m) && o.radius_m > 0, o.name + ": radius");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < kHeader) return 0;
  const int width = 8 + data[0] % 153, height = 8 + data[1] % 153;
  const int choice = data[2] & 3;
  const double decimates[4] = {1, 1.5, 2, 2};
  const double decimate = decimates[(data[2] >> 2) & 3];
  const bool draw = data[2] & 0x10, second = data[2] & 0x20, same_id = data[2] & 0x40,
             bilinear = data[2] & 0x80;
  const std::string family = kChoices[choice].family;
  const int count = ptz::markerFamilyCount(family);
  FUZZ_CHECK(count > 0, family + ": no ids");
  const int id = (data[3] | data[4] << 8) % count;
  const int other_id = same_id ? id : (id + 1) % count;
  const int side = 8 + data[5] % 160;
  const int disparity = (data[11] & 0x3f) - 8, drop = data[11] >> 6;
  const double size_m = 0.02 + data[16] * 0.004;
  const double zoom = 1 + data[17] * 9.0 / 255;

  // The picture both images are cut from: a window at `left_x` and one at `right_x`.
  const int left_x = disparity < 0 ? -disparity : 0, right_x = disparity > 0 ? disparity : 0;
  cv::Mat picture(height + drop, width + std::abs(disparity), CV_8UC1);
  const uint8_t* pixels = data + kHeader;
  const size_t n = size - kHeader;
  for (int r = 0; r < picture.rows; ++r) {
    uchar* row = picture.ptr<uchar>(r);
    for (int c = 0; c < picture.cols; ++c) {
      const size_t i =
          static_cast<size_t>(r) * static_cast<size_t>(picture.cols) + static_cast<size_t>(c);
      row[c] = n ? pixels[i % n] : 128;
    }
  }
  if (draw) {
    const cv::Point2d centre(left_x + data[6] * (width + side) / 255.0 - side / 2.0,
                             data[7] * (height + side) / 255.0 - side / 2.0);
    const double turn_deg = data[8] * 360.0 / 256;
    drawTag(picture, family, id, side, centre, turn_deg, bilinear);
    if (second) {
      const cv::Point2d shift(static_cast<int8_t>(data[9]), static_cast<int8_t>(data[10]));
      drawTag(picture, family, other_id, side, centre + shift, turn_deg, bilinear);
    }
  }
  const cv::Mat left = picture(cv::Rect(left_x, 0, width, height));
  const cv::Mat right = picture(cv::Rect(right_x, drop, width, height));

  // Both images are windows of the default rig's VGA frames about their middle (where a pure
  // shift between the views is nearly what the rig sees), on even pixels.
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  const cv::Point window((rig.left.width - width) / 2 & ~1, (rig.left.height - height) / 2 & ~1);
  std::vector<MarkerSighting> seen[2];
  seen[0] = detect(choice, left, window, decimate);
  seen[1] = detect(choice, right, window, decimate);
  // A part, as MarkerScanner cuts windows and bands: its corner on even pixels.
  const int part_x = (data[12] % width) & ~1, part_y = (data[13] % height) & ~1;
  const cv::Rect part(part_x, part_y, 1 + data[14] % (width - part_x),
                      1 + data[15] % (height - part_y));
  detect(choice, left(part), window + part.tl(), decimate);

  const ptz::PtzPose pose{0, 0, zoom};
  const ptz::CameraView left_view = rig.view(ptz::Side::kLeft, pose);
  const ptz::CameraView right_view = rig.view(ptz::Side::kRight, pose);

  // Single tags: any id.
  objects({singleClass(choice, size_m)}, seen, left_view, right_view);
  // A bundle of the tags drawn (the first on the object's -z face, the other on its +x face); the
  // sightings of its ids become its.
  MarkerClass bundle = singleClass(choice, size_m);
  bundle.name = "box";
  bundle.any_id = false;
  ptz::perception::MarkerTag face;
  face.id = id;
  face.centre_m = {0, 0, -size_m / 2};
  face.rotation_object_tag = ptz::tagRotation(0, 0);
  bundle.bundle.push_back(face);
  if (other_id != id) {
    face.id = other_id;
    face.centre_m = {size_m / 2, 0, 0};
    face.rotation_object_tag = ptz::tagRotation(-90, 0);
    bundle.bundle.push_back(face);
  }
  std::vector<MarkerSighting> bundle_seen[2];
  for (int s = 0; s < 2; ++s) {
    for (const MarkerSighting& m : seen[s]) {
      if (!bundle.bundleTag(m.id)) continue;
      bundle_seen[s].push_back(m);
      bundle_seen[s].back().class_index = 0;
    }
  }
  objects({bundle}, bundle_seen, left_view, right_view);
  return 0;
}
