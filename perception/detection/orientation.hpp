// A box's yaw from both views' outlines (no LCM). The box is upright (its faces vertical and
// horizontal in the head frame, y down) with a square footprint, so its yaw about the head's y
// axis is defined modulo 90 degrees and reported in [-45, 45). A model box at the triangulated
// centre is projected into both cameras with the frame's own views; its size is fitted to the
// regions' extents at each yaw, its outline (the hull of its 8 corners) shifted onto each region's
// centroid, and the yaw is the one whose outlines differ least from the regions' masks (pixels in
// one and not the other), coarse to fine. Two outlines that are near mirror images (the top face
// barely seen) are told apart by the shading step along the vertical edge between the two visible
// side faces. The uncertainty comes from the cost's curvature at its minimum.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "common/rig.hpp"
#include "perception/detection/detector.hpp"

namespace ptz::perception {

struct OrientationParams {
  // The boxes' height over their footprint's side (1: cubes): the size is then fitted to the
  // regions' heights and their widths tell the yaw. 0: both fitted (the widths then tell little
  // when the top face is not seen).
  double height_ratio = 1.0;
  double coarse_step_deg = 3.0;  // first pass over the 90-degree period
  double fine_step_deg = 0.1;    // the search stops at this step
  // A second minimum within this factor of the best one's cost is a mirror candidate, decided
  // by the shading step.
  double mirror_cost_ratio = 1.6;
  // Boundary noise of an outline, px per pixel of perimeter: the cost a yaw error must exceed
  // to be seen, which scales the curvature into a variance.
  double boundary_noise_px = 0.1;
  double min_sigma_deg = 0.5;  // floor of the reported sigma
  int min_area_px2 = 60;       // regions smaller than this in either view: no estimate
};

// Whether a class's objects have an orientation: boxes and other non-round shapes do, a class
// whose template is a circle (a sphere) does not.
bool classHasOrientation(const ColorClass& c);

// The crop of an image (size `image`) the estimate needs around a region: its box and margin_px.
cv::Rect boxCrop(const cv::Rect& region_bbox, const cv::Size& image, int margin_px);

// Whether a region touches the image's border (part of the box may be outside: no estimate).
bool regionCut(const cv::Rect& region_bbox, const cv::Size& image);

// One view of the box: the class's mask and the grey image of a crop around its region (pixels of
// the full image from origin), and the camera at the frame's pan/tilt/zoom.
struct BoxView {
  cv::Mat mask;  // CV_8U, 255 where the region is (other regions cleared)
  cv::Mat gray;  // CV_8U, the same size
  cv::Point origin;
  CameraView view;
};

// The crop's mask (only the pixels of the region within region_bbox, the class's segmentation
// as Detector makes it, median filter first) and grey image. bgr_crop: BGR8, full-image pixels
// from origin.
BoxView makeBoxView(const Detector& detector, size_t class_index, const cv::Mat& bgr_crop,
                    const cv::Point& origin, const cv::Rect& region_bbox, const CameraView& view);

struct BoxYaw {
  bool ok = false;
  double yaw_rad = 0;        // in [-pi/4, pi/4)
  double variance_rad2 = 0;  // from the cost's curvature
  double cost = 0;           // mismatch at the minimum, fraction of the regions' area
  // Fitted half extents (footprint, height), m.
  double half_width_m = 0, half_height_m = 0;
  bool mirror_decided = false;  // a mirror candidate was decided by the shading step
  int evaluations = 0;
  const char* why = "";  // when !ok
};

// The yaw of the box centred near centre_head_m (triangulated) seen in both views.
BoxYaw estimateBoxYaw(const BoxView& left, const BoxView& right,
                      const Eigen::Vector3d& centre_head_m, const OrientationParams& params = {});

}  // namespace ptz::perception
