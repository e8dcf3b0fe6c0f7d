// The scene cloud: coloured head-frame points through a voxel grid (PCL's, without PCL) and
// PCL's statistical outlier removal, packed in PCL's layout (pcl::PointXYZRGB) as a
// point_cloud_t, and written as PCD. PCL stays inside cloud.cpp: this header is cheap to include.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "ptzstereo/point_cloud_t.hpp"

namespace ptz {
class Params;
}

namespace ptz::perception {

struct CloudParams {
  double voxel_size_m = 0.05;  // <= 0: no downsampling
  int sor_mean_k = 0;          // neighbours of PCL's statistical outlier removal (0: off; ptz-depth
                               // removes outliers on its pixel grid instead, outlier_stddev_mult)
  double sor_stddev_mult = 2.0;

  static CloudParams fromParams(const Params& params);
};
void declareCloudParams(Params& params);

// Buffers of voxelGridFilter, kept between frames.
struct VoxelGridScratch {
  std::vector<uint32_t> key, order, swap;
};
// PCL's VoxelGrid (1.13) without PCL's copies, ~4x faster: the centroid and the mean colour
// (truncated) of each occupied voxel of leaf_m, in the order of the voxels' index. The points of
// a voxel are summed in their order (PCL leaves it to its sort: centroids may differ in the last
// bit). Leaves too small for 32-bit voxel indices keep every point, as PCL does.
void voxelGridFilter(const std::vector<cv::Point3f>& points, const std::vector<cv::Vec3b>& colours,
                     double leaf_m, std::vector<cv::Point3f>* out_points,
                     std::vector<cv::Vec3b>* out_colours, VoxelGridScratch* scratch = nullptr);

// Filters the points and packs them (x, y, z, rgb; PCL's 32-byte PointXYZRGB) with frame_id
// "head"; the caller stamps utime, frame_seq and publish_utime. Keeps its buffers, and those of
// the cloud it fills, between frames: no allocation (nor page faults) once the sizes settle.
class CloudMaker {
 public:
  explicit CloudMaker(CloudParams params) : params_(params) {}
  void make(const std::vector<cv::Point3f>& points_head_m,
            const std::vector<cv::Vec3b>& colours_bgr, ptzstereo::point_cloud_t* cloud);
  const CloudParams& params() const { return params_; }

 private:
  CloudParams params_;
  VoxelGridScratch scratch_;
  std::vector<cv::Point3f> points_;
  std::vector<cv::Vec3b> colours_;
};
// The same for a single cloud.
ptzstereo::point_cloud_t makeCloud(const std::vector<cv::Point3f>& points_head_m,
                                   const std::vector<cv::Vec3b>& colours_bgr,
                                   const CloudParams& params);

// Every k-th point of a cloud made by makeCloud, k the smallest that keeps its data within
// max_bytes: a preview that crosses a LAN in one datagram. An empty cloud for a layout it does
// not know (point_step or sizes that disagree).
ptzstereo::point_cloud_t decimateCloud(const ptzstereo::point_cloud_t& cloud, int64_t max_bytes);

// The xyz of every point of a cloud in PCL's layout (NaN points skipped); false if the layout
// has no float x, y, z fields or its sizes disagree.
bool cloudPoints(const ptzstereo::point_cloud_t& cloud, std::vector<cv::Point3f>* points);

// pcl_viewer's camera (a `-cam FILE.cam` line) that shows head-frame points upright: from the
// head's origin towards their centroid, up = -y, all of them in view. pcl_viewer ignores the
// PCD's VIEWPOINT for this (it moves the cloud with the camera), so the points, which stay in
// the head frame (y down), would otherwise open upside down.
std::string pclViewerCamera(const std::vector<cv::Point3f>& points_head_m);
// Where writePcd puts that camera: the PCD's path with .cam for .pcd.
std::string pclViewerCameraPath(const std::string& pcd_path);

// Binary PCD and its pcl_viewer camera beside it (`pcl_viewer X.pcd -cam X.cam` shows it
// upright). False with a message naming the file when either cannot be written.
bool writePcd(const ptzstereo::point_cloud_t& cloud, const std::string& path, std::string* error);

// ptz-depth's --pcd-path PATTERN for the clouds_made-th cloud (1-based) of frame seq: PATTERN
// with {seq} replaced, when it is due (every every_n-th cloud, the first; every_n 0: the first
// only); empty when none is.
std::string pcdPathIfDue(const std::string& pattern, int every_n, int64_t clouds_made, int64_t seq);

}  // namespace ptz::perception
