// All of the project's PCL code.
#include "perception/depth/cloud.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/point_tests.h>
#include <pcl/conversions.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "common/config.hpp"

namespace ptz::perception {

void declareCloudParams(Params& p) {
  p.add("voxel_size_m", 0.05, "m", "voxel grid leaf size (<= 0: no downsampling)");
  p.add("sor_mean_k", 0, "",
        "PCL's statistical outlier removal on the cloud: neighbours (0: off; costs ~2.7 us a "
        "point, outlier_stddev_mult does it on the pixel grid for far less)",
        Range::between(0, 1000));
  p.add("sor_stddev_mult", 2.0, "",
        "statistical outlier removal: drop points this many standard deviations away",
        Range::above(0));
}

CloudParams CloudParams::fromParams(const Params& p) {
  CloudParams c;
  c.voxel_size_m = p.getDouble("voxel_size_m");
  c.sor_mean_k = p.getInt("sor_mean_k");
  c.sor_stddev_mult = p.getDouble("sor_stddev_mult");
  return c;
}

ptzstereo::point_cloud_t makeCloud(const std::vector<cv::Point3f>& points,
                                   const std::vector<cv::Vec3b>& colours,
                                   const CloudParams& params) {
  using Cloud = pcl::PointCloud<pcl::PointXYZRGB>;
  Cloud::Ptr cloud(new Cloud);
  cloud->resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    pcl::PointXYZRGB& q = (*cloud)[i];
    q.x = points[i].x;
    q.y = points[i].y;
    q.z = points[i].z;
    q.b = colours[i][0];
    q.g = colours[i][1];
    q.r = colours[i][2];
  }
  cloud->width = static_cast<uint32_t>(cloud->size());
  cloud->height = 1;
  cloud->is_dense = true;
  if (params.voxel_size_m > 0 && !cloud->empty()) {
    Cloud::Ptr down(new Cloud);
    pcl::VoxelGrid<pcl::PointXYZRGB> grid;
    const float leaf = static_cast<float>(params.voxel_size_m);
    grid.setLeafSize(leaf, leaf, leaf);
    grid.setInputCloud(cloud);
    grid.filter(*down);
    cloud = down;
  }
  if (params.sor_mean_k > 0 && cloud->size() > static_cast<size_t>(params.sor_mean_k)) {
    Cloud::Ptr kept(new Cloud);
    pcl::StatisticalOutlierRemoval<pcl::PointXYZRGB> sor;
    sor.setMeanK(params.sor_mean_k);
    sor.setStddevMulThresh(params.sor_stddev_mult);
    sor.setInputCloud(cloud);
    sor.filter(*kept);
    cloud = kept;
  }
  pcl::PCLPointCloud2 packed;
  pcl::toPCLPointCloud2(*cloud, packed);
  ptzstereo::point_cloud_t msg{};
  msg.frame_id = "head";
  msg.width = static_cast<int32_t>(packed.width);
  msg.height = static_cast<int32_t>(packed.height);
  msg.is_dense = packed.is_dense;
  msg.is_bigendian = packed.is_bigendian;
  for (const auto& f : packed.fields) {
    msg.fields.push_back({f.name, static_cast<int32_t>(f.offset), static_cast<int8_t>(f.datatype),
                          static_cast<int32_t>(f.count)});
  }
  msg.num_fields = static_cast<int32_t>(msg.fields.size());
  msg.point_step = static_cast<int32_t>(packed.point_step);
  msg.row_step = static_cast<int32_t>(packed.row_step);
  msg.data = std::move(packed.data);
  msg.data_size = static_cast<int32_t>(msg.data.size());
  return msg;
}

namespace {

bool toPcl(const ptzstereo::point_cloud_t& m, pcl::PCLPointCloud2* c) {
  if (m.width < 0 || m.height < 0 || m.point_step <= 0 ||
      static_cast<int64_t>(m.width) * m.height * m.point_step > m.data_size ||
      m.data_size != static_cast<int32_t>(m.data.size())) {
    return false;
  }
  c->width = static_cast<uint32_t>(m.width);
  c->height = static_cast<uint32_t>(m.height);
  c->is_dense = m.is_dense;
  c->is_bigendian = m.is_bigendian;
  c->point_step = static_cast<uint32_t>(m.point_step);
  c->row_step = static_cast<uint32_t>(m.row_step);
  for (const auto& f : m.fields) {
    pcl::PCLPointField pf;
    pf.name = f.name;
    pf.offset = static_cast<uint32_t>(f.offset);
    pf.datatype = static_cast<uint8_t>(f.datatype);
    pf.count = static_cast<uint32_t>(f.count);
    c->fields.push_back(pf);
  }
  c->data = m.data;
  return true;
}

}  // namespace

ptzstereo::point_cloud_t decimateCloud(const ptzstereo::point_cloud_t& cloud, int64_t max_bytes) {
  ptzstereo::point_cloud_t out = cloud;  // a copy at the preview's rate (1 Hz), then the points
  out.data.clear();
  out.width = 0;
  out.height = 1;
  const int64_t step = cloud.point_step;
  const int64_t points = static_cast<int64_t>(cloud.width) * cloud.height;
  if (step <= 0 || points <= 0 || points * step != static_cast<int64_t>(cloud.data.size()) ||
      max_bytes < step) {
    out.row_step = 0;
    out.data_size = 0;
    return out;
  }
  const int64_t keep_at_most = max_bytes / step;
  const int64_t k = (points + keep_at_most - 1) / keep_at_most;
  for (int64_t i = 0; i < points; i += k) {
    const auto from = cloud.data.begin() + static_cast<ptrdiff_t>(i * step);
    out.data.insert(out.data.end(), from, from + static_cast<ptrdiff_t>(step));
  }
  out.width = static_cast<int32_t>(out.data.size() / static_cast<size_t>(step));
  out.row_step = out.width * cloud.point_step;
  out.data_size = static_cast<int32_t>(out.data.size());
  return out;
}

bool cloudPoints(const ptzstereo::point_cloud_t& m, std::vector<cv::Point3f>* points) {
  pcl::PCLPointCloud2 packed;
  if (!toPcl(m, &packed)) return false;
  for (const char* name : {"x", "y", "z"}) {
    if (pcl::getFieldIndex(packed, name) < 0) return false;
  }
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl::fromPCLPointCloud2(packed, xyz);
  points->clear();
  for (const auto& p : xyz) {
    if (pcl::isFinite(p)) points->emplace_back(p.x, p.y, p.z);
  }
  return true;
}

std::string pclViewerCamera(const std::vector<cv::Point3f>& points) {
  // Looking from the head's origin at the points' centroid, up = -y (the head frame's y points
  // down), the vertical field of view just wide enough for every point in a 4:3 window.
  constexpr int kWidthPx = 1024, kHeightPx = 768;
  cv::Vec3d centroid(0, 0, 0);
  size_t n = 0;
  for (const auto& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || p.z <= 0) continue;
    centroid += cv::Vec3d(p.x, p.y, p.z);
    ++n;
  }
  cv::Vec3d view = n > 0 ? centroid / static_cast<double>(n) : cv::Vec3d(0, 0, 1);
  if (cv::norm(view) < 1e-9) view = {0, 0, 1};
  const double distance_m = cv::norm(view);
  view /= distance_m;
  cv::Vec3d up = cv::Vec3d(0, -1, 0) - view * view.dot(cv::Vec3d(0, -1, 0));
  if (cv::norm(up) < 1e-6) up = {0, 0, 1};  // looking straight up or down
  up /= cv::norm(up);
  const cv::Vec3d right = view.cross(up);
  const double aspect = static_cast<double>(kWidthPx) / kHeightPx;
  double tan_half = 0, far_m = 1;
  for (const auto& p : points) {
    const cv::Vec3d q(p.x, p.y, p.z);
    const double depth = q.dot(view);
    if (!std::isfinite(depth) || depth <= 1e-6) continue;
    tan_half = std::max(
        {tan_half, std::fabs(q.dot(up)) / depth, std::fabs(q.dot(right)) / (depth * aspect)});
    far_m = std::max(far_m, cv::norm(q));
  }
  const double fovy_rad =
      std::clamp(2 * std::atan(1.1 * tan_half), 5.0 * CV_PI / 180, 150.0 * CV_PI / 180);
  const cv::Vec3d focal = view * distance_m;
  std::ostringstream cam;
  cam.precision(9);
  // clip near,far / focal point / position / view up / fovy (rad) / window size / window pos
  cam << 0.01 << "," << 2 * far_m << "/" << focal[0] << "," << focal[1] << "," << focal[2]
      << "/0,0,0/" << up[0] << "," << up[1] << "," << up[2] << "/" << fovy_rad << "/" << kWidthPx
      << "," << kHeightPx << "/0,0\n";
  return cam.str();
}

std::string pclViewerCameraPath(const std::string& pcd_path) {
  const std::string ext = ".pcd";
  const bool has_ext =
      pcd_path.size() > ext.size() && pcd_path.compare(pcd_path.size() - 4, 4, ext) == 0;
  return (has_ext ? pcd_path.substr(0, pcd_path.size() - 4) : pcd_path) + ".cam";
}

bool writePcd(const ptzstereo::point_cloud_t& m, const std::string& path, std::string* error) {
  pcl::PCLPointCloud2 packed;
  if (!toPcl(m, &packed)) {
    *error = "PCD file '" + path + "': the cloud's sizes disagree";
    return false;
  }
  // PCL only says "error during open"; find out why first, for a message that helps.
  {
    std::ofstream probe(path, std::ios::binary | std::ios::app);
    if (!probe) {
      *error = "cannot write PCD file '" + path + "': " + std::strerror(errno);
      return false;
    }
  }
  try {
    pcl::PCDWriter writer;
    if (writer.writeBinary(path, packed) != 0) {
      *error = "cannot write PCD file '" + path + "'";
      return false;
    }
  } catch (const std::exception& e) {
    *error = "cannot write PCD file '" + path + "': " + e.what();
    return false;
  }
  // The cloud stays in the head frame (y down); the view that shows it upright goes beside it.
  std::vector<cv::Point3f> points;
  cloudPoints(m, &points);
  const std::string cam_path = pclViewerCameraPath(path);
  std::ofstream cam(cam_path);
  cam << pclViewerCamera(points);
  cam.close();
  if (!cam) {
    *error = "cannot write pcl_viewer camera file '" + cam_path + "': " + std::strerror(errno);
    return false;
  }
  return true;
}

}  // namespace ptz::perception
