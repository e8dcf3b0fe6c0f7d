// Left/right association of 2D regions with the epipolar constraint of the frame's own geometry
// (the rig model at the frame's pan/tilt/zoom), and triangulation in the head frame with a
// covariance propagated from pixel noise.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "common/rig.hpp"
#include "perception/detection/detector.hpp"
#include "perception/tracking/tracker.hpp"

namespace ptz::perception {

struct StereoParams {
  double max_epipolar_px = 3.0;  // largest distance of a match from its epipolar line
  double max_area_ratio = 2.0;   // largest area ratio (after correcting for focal lengths)
  double pixel_sigma_px = 0.3;   // centroid noise, for the covariance
  double min_range_m = 0.3;
  double max_range_m = 50.0;
};

struct StereoObject {
  int left = -1, right = -1;  // indices into the left and right regions
  int class_index = -1;
  Eigen::Vector3d position_head_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_m2 = Eigen::Matrix3d::Zero();
  double epipolar_px = 0;
};

// A pixel of the view's (distorted) image as a unit ray in the head frame.
Eigen::Vector3d pixelRay(const CameraView& view, const Eigen::Vector2d& pixel);

// The point nearest both rays (midpoint of the shortest segment between them); false if the
// rays are parallel or the point is behind a camera.
bool triangulate(const CameraView& left, const CameraView& right, const Eigen::Vector2d& left_px,
                 const Eigen::Vector2d& right_px, Eigen::Vector3d* point_head,
                 double* epipolar_px = nullptr);

// Covariance of the triangulated point for isotropic pixel noise sigma_px in both images
// (first-order propagation through triangulate()).
Eigen::Matrix3d triangulationCovariance(const CameraView& left, const CameraView& right,
                                        const Eigen::Vector2d& left_px,
                                        const Eigen::Vector2d& right_px, double sigma_px);

// Pairs regions of the same class, best (smallest epipolar distance) first, each region once.
std::vector<StereoObject> associate(const std::vector<Region>& left,
                                    const std::vector<Region>& right, const CameraView& left_view,
                                    const CameraView& right_view, const StereoParams& params);

// Physical radius of the object of a region: the apparent radius of a disc of the region's area,
// back to metres at the object's range from the camera.
double objectRadiusM(const Region& region, const Eigen::Vector3d& position_head_m,
                     const CameraView& view);

// The tracker's input: each object with the reason it cannot be trusted as the object's centre
// ("border": its region touches an image border in either view; "touching": in either view its
// shape (a disc for round regions, else its box) comes within 2 px of another region's (but for
// discs split from one blob), so one may be hiding part of the other; "overlap": in either view
// its region covers the predicted images of two or more tracks of its class, i.e. objects merged
// into one region whose triangulated centre is neither's (for a split disc: two tracks predicted
// within half its radius of its centre); "lr_area": the areas of the two views, corrected for their
// focal lengths, differ by more than trusted_area_ratio). A split disc's pixel sigma is twice a
// region's, and more when less than 60 % of its circle is seen (as 0.6 / the share). tracks: the
// tracker's tracks before this frame, predicted here to t_s.
std::vector<TrackMeasurement> trackMeasurements(
    const std::vector<StereoObject>& objects, const std::vector<Region>& left,
    const std::vector<Region>& right, const CameraView& left_view, const CameraView& right_view,
    const std::vector<std::string>& class_names, double trusted_area_ratio,
    const std::vector<Track>& tracks, double t_s);

// Each camera's regions that no stereo pair used and that can be trusted as an object's centre
// by the rules of trackMeasurements for one view (not at a border, touching another region, or
// over two tracks), as one-view measurements of pixel noise sigma_px (a split disc's more, as in
// trackMeasurements).
std::vector<ViewMeasurement> viewMeasurements(
    const std::vector<StereoObject>& objects, const std::vector<Region>& left,
    const std::vector<Region>& right, const CameraView& left_view, const CameraView& right_view,
    const std::vector<std::string>& class_names, double sigma_px, const std::vector<Track>& tracks,
    double t_s);

}  // namespace ptz::perception
