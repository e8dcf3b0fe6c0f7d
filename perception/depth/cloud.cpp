// All of the project's PCL code.
#include "perception/depth/cloud.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/point_tests.h>
#include <pcl/conversions.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
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

void voxelGridFilter(const std::vector<cv::Point3f>& points, const std::vector<cv::Vec3b>& colours,
                     double leaf_m, std::vector<cv::Point3f>* out_points,
                     std::vector<cv::Vec3b>* out_colours, VoxelGridScratch* scratch) {
  CV_Assert(colours.size() == points.size() && leaf_m > 0);
  out_points->clear();
  out_colours->clear();
  const size_t n = points.size();
  if (n == 0) return;
  // PCL's arithmetic, in float, step by step: the same voxel for every point.
  const float inverse_leaf = 1.0f / static_cast<float>(leaf_m);
  cv::Point3f lo = points[0], hi = points[0];
  for (const cv::Point3f& p : points) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const int64_t dx = static_cast<int64_t>((hi.x - lo.x) * inverse_leaf) + 1;
  const int64_t dy = static_cast<int64_t>((hi.y - lo.y) * inverse_leaf) + 1;
  const int64_t dz = static_cast<int64_t>((hi.z - lo.z) * inverse_leaf) + 1;
  if (dx * dy * dz > std::numeric_limits<int32_t>::max()) {
    *out_points = points;
    *out_colours = colours;
    return;
  }
  const auto cellOf = [inverse_leaf](float v) {
    return static_cast<int>(std::floor(v * inverse_leaf));
  };
  const int min_x = cellOf(lo.x), min_y = cellOf(lo.y), min_z = cellOf(lo.z);
  const int div_x = cellOf(hi.x) - min_x + 1, div_y = cellOf(hi.y) - min_y + 1;
  VoxelGridScratch local;
  VoxelGridScratch& buffers = scratch ? *scratch : local;
  std::vector<uint32_t>& key = buffers.key;
  std::vector<uint32_t>& order = buffers.order;
  std::vector<uint32_t>& swap = buffers.swap;
  key.resize(n);
  order.resize(n);
  swap.resize(n);
  uint32_t max_key = 0;
  for (size_t i = 0; i < n; ++i) {
    const cv::Point3f& p = points[i];
    const int ix = static_cast<int>(std::floor(p.x * inverse_leaf) - static_cast<float>(min_x));
    const int iy = static_cast<int>(std::floor(p.y * inverse_leaf) - static_cast<float>(min_y));
    const int iz = static_cast<int>(std::floor(p.z * inverse_leaf) - static_cast<float>(min_z));
    key[i] = static_cast<uint32_t>(ix + iy * div_x + iz * div_x * div_y);
    max_key = std::max(max_key, key[i]);
    order[i] = static_cast<uint32_t>(i);
  }
  // Stable LSD radix sort of the points by voxel, 11 bits a pass.
  constexpr int kBits = 11;
  constexpr uint32_t kMask = (1u << kBits) - 1;
  for (int shift = 0; shift < 32 && (max_key >> shift) != 0; shift += kBits) {
    std::array<uint32_t, (1u << kBits) + 1> start{};
    for (uint32_t i : order) ++start[((key[i] >> shift) & kMask) + 1];
    for (size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
    for (uint32_t i : order) swap[start[(key[i] >> shift) & kMask]++] = i;
    order.swap(swap);
  }
  for (size_t first = 0; first < n;) {
    const uint32_t k = key[order[first]];
    float x = 0, y = 0, z = 0, b = 0, g = 0, r = 0;
    size_t last = first;
    for (; last < n && key[order[last]] == k; ++last) {
      const cv::Point3f& p = points[order[last]];
      const cv::Vec3b& c = colours[order[last]];
      x += p.x;
      y += p.y;
      z += p.z;
      b += c[0];
      g += c[1];
      r += c[2];
    }
    const float count = static_cast<float>(last - first);
    out_points->emplace_back(x / count, y / count, z / count);
    out_colours->emplace_back(static_cast<uchar>(b / count), static_cast<uchar>(g / count),
                              static_cast<uchar>(r / count));
    first = last;
  }
}

void CloudMaker::make(const std::vector<cv::Point3f>& points, const std::vector<cv::Vec3b>& colours,
                      ptzstereo::point_cloud_t* cloud) {
  const std::vector<cv::Point3f>* p = &points;
  const std::vector<cv::Vec3b>* c = &colours;
  if (params_.voxel_size_m > 0) {
    voxelGridFilter(points, colours, params_.voxel_size_m, &points_, &colours_, &scratch_);
    p = &points_;
    c = &colours_;
  }
  if (params_.sor_mean_k > 0 && p->size() > static_cast<size_t>(params_.sor_mean_k)) {
    using Cloud = pcl::PointCloud<pcl::PointXYZRGB>;
    Cloud::Ptr in(new Cloud);
    in->resize(p->size());
    for (size_t i = 0; i < p->size(); ++i) {
      pcl::PointXYZRGB& q = (*in)[i];
      q.x = (*p)[i].x;
      q.y = (*p)[i].y;
      q.z = (*p)[i].z;
      q.b = (*c)[i][0];
      q.g = (*c)[i][1];
      q.r = (*c)[i][2];
    }
    Cloud kept;
    pcl::StatisticalOutlierRemoval<pcl::PointXYZRGB> sor;
    sor.setMeanK(params_.sor_mean_k);
    sor.setStddevMulThresh(params_.sor_stddev_mult);
    sor.setInputCloud(in);
    sor.filter(kept);
    std::vector<cv::Point3f> kept_points;
    std::vector<cv::Vec3b> kept_colours;
    for (const pcl::PointXYZRGB& q : kept) {
      kept_points.emplace_back(q.x, q.y, q.z);
      kept_colours.emplace_back(q.b, q.g, q.r);
    }
    points_.swap(kept_points);
    colours_.swap(kept_colours);
    p = &points_;
    c = &colours_;
  }
  // pcl::toPCLPointCloud2's packing of pcl::PointXYZRGB, written in place: x, y, z, w = 1 at 0,
  // rgba (b, g, r, 255 from the lowest byte) at 16, padding to 32.
  static_assert(sizeof(pcl::PointXYZRGB) == 32);
  constexpr int32_t kPointBytes = 32, kRgbOffsetBytes = 16;
  const int8_t kFloat = ptzstereo::point_field_t::FLOAT32;
  const auto n = static_cast<int32_t>(p->size());
  ptzstereo::point_cloud_t& m = *cloud;
  m.frame_id = "head";
  m.width = n;
  m.height = 1;
  m.is_dense = true;
  m.is_bigendian = false;
  m.fields = {{"x", 0, kFloat, 1},
              {"y", 4, kFloat, 1},
              {"z", 8, kFloat, 1},
              {"rgb", kRgbOffsetBytes, kFloat, 1}};
  m.num_fields = static_cast<int32_t>(m.fields.size());
  m.point_step = kPointBytes;
  m.row_step = kPointBytes * n;
  m.data.assign(static_cast<size_t>(kPointBytes) * p->size(), 0);
  for (size_t i = 0; i < p->size(); ++i) {
    uint8_t* d = m.data.data() + i * kPointBytes;
    const cv::Point3f& q = (*p)[i];
    const cv::Vec3b& bgr = (*c)[i];
    const float xyzw[4] = {q.x, q.y, q.z, 1.0f};
    const uint32_t rgba = 0xff000000u | static_cast<uint32_t>(bgr[2]) << 16 |
                          static_cast<uint32_t>(bgr[1]) << 8 | bgr[0];
    std::memcpy(d, xyzw, sizeof(xyzw));
    std::memcpy(d + kRgbOffsetBytes, &rgba, sizeof(rgba));
  }
  m.data_size = static_cast<int32_t>(m.data.size());
}

ptzstereo::point_cloud_t makeCloud(const std::vector<cv::Point3f>& points,
                                   const std::vector<cv::Vec3b>& colours,
                                   const CloudParams& params) {
  ptzstereo::point_cloud_t cloud{};
  CloudMaker(params).make(points, colours, &cloud);
  return cloud;
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

std::string pcdPathIfDue(const std::string& pattern, int every_n, int64_t clouds_made,
                         int64_t seq) {
  if (pattern.empty() || clouds_made < 1) return "";
  const bool due = every_n > 0 ? (clouds_made - 1) % every_n == 0 : clouds_made == 1;
  if (!due) return "";
  std::string path = pattern;
  const auto at = path.find("{seq}");
  if (at != std::string::npos) path.replace(at, 5, std::to_string(seq));
  return path;
}

}  // namespace ptz::perception
