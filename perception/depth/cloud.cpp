// All of the project's PCL code.
#include "perception/depth/cloud.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/point_tests.h>
#include <pcl/conversions.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cerrno>
#include <cstring>
#include <fstream>

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
  return true;
}

}  // namespace ptz::perception
