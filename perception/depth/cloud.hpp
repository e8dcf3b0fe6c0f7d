// The scene cloud: coloured head-frame points through PCL's voxel grid and statistical outlier
// removal, packed in PCL's layout (pcl::PointXYZRGB) as a point_cloud_t, and written as PCD.
// PCL stays inside cloud.cpp: this header is cheap to include.
#pragma once

#include <opencv2/core.hpp>

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

// Filters the points and packs them (x, y, z, rgb; PCL's 32-byte PointXYZRGB) with frame_id
// "head"; the caller stamps utime, frame_seq and publish_utime.
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

}  // namespace ptz::perception
