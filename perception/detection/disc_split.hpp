// Merged blobs of round objects split into their discs. Two balls of one colour that overlap in
// an image (one in front of the other, or side by side) make one region that fails the circle
// shape test. Its outer contour is then made of arcs of their circles: each circle is found by
// RANSAC on the contour points (a fixed seed: the same blob gives the same answer, so lockstep
// runs repeat), refined by a least-squares fit to its inliers, and kept when enough of its
// circumference supports it and its disc lies inside the region (the hidden part of a ball behind
// another is covered by the one in front, which is in the region too). A disc cut by an object of
// another colour is not inside the region: such a region gives no disc.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

namespace ptz::perception {

struct Disc {
  cv::Point2d centre_px;
  double radius_px = 0;
  double arc_fraction = 0;  // share of its circumference on the region's contour (0..1)
  double rms_px = 0;        // of its inliers' distances from the circle
};

struct DiscSplitParams {
  // A contour point is on a circle within max(inlier_px, inlier_share * radius): a sphere off
  // the optical axis projects to an ellipse, about 1/cos(angle) long.
  double inlier_px = 1.0;
  double inlier_share = 0.03;
  double min_arc_fraction = 0.3;  // less is no evidence of a circle
  double min_inside = 0.97;       // share of a disc's pixels that must be the region's
  double min_covered = 0.85;      // share of the region's pixels the discs must explain
  int max_discs = 4;
  int iterations = 250;  // RANSAC samples per disc at most (fewer once 99.9 % sure of the best)
};

// The circle through three points; false when they are (nearly) on a line.
bool circleThrough(const cv::Point2d& a, const cv::Point2d& b, const cv::Point2d& c,
                   cv::Point2d* centre, double* radius);

// The algebraic least-squares circle (Kasa) of at least three points; false when degenerate.
bool fitCircle(const std::vector<cv::Point2d>& points, cv::Point2d* centre, double* radius);

// The discs of a region: contour (its outer border, CHAIN_APPROX_NONE, image coordinates) and
// mask (the region alone, 255 inside, whose top-left pixel is at mask_origin). Discs of radius
// below min_radius_px are not looked for. Largest support first; empty when the region is not
// made of discs (too little of it explained, or no circle with enough support). *covered: the
// share of the region's pixels inside the discs.
std::vector<Disc> splitDiscs(const std::vector<cv::Point>& contour, const cv::Mat& mask,
                             const cv::Point& mask_origin, double min_radius_px,
                             const DiscSplitParams& params = {}, double* covered = nullptr);

}  // namespace ptz::perception
