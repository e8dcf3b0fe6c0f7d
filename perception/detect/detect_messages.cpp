#include "perception/detect/detect_messages.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include "perception/tracking/yaw.hpp"

namespace ptz::perception {
namespace {

void copyMatrix(const Eigen::Matrix3d& m, double* out) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out[r * 3 + c] = m(r, c);
  }
}

// Rotation head <- object of a yaw about the head's y axis, its variance the y-y entry.
void copyYaw(double yaw_rad, double var_rad2, double* wxyz, double* covariance) {
  const Eigen::Vector4d q = yawQuaternionWxyz(yaw_rad);
  for (int i = 0; i < 4; ++i) wxyz[i] = q[i];
  for (int i = 0; i < 9; ++i) covariance[i] = 0;
  covariance[4] = var_rad2;
}

void copyRotation(const Eigen::Quaterniond& q, const Eigen::Matrix3d& covariance, double* wxyz,
                  double* covariance_out) {
  wxyz[0] = q.w(), wxyz[1] = q.x(), wxyz[2] = q.y(), wxyz[3] = q.z();
  copyMatrix(covariance, covariance_out);
}

}  // namespace

ptzstereo::detection_2d_t toMessage(const MarkerSighting& s, const std::string& object_name) {
  ptzstereo::detection_2d_t d{};
  d.class_name = object_name;
  d.centroid_x_px = s.centre_px.x;
  d.centroid_y_px = s.centre_px.y;
  std::vector<cv::Point2f> quad;
  for (const auto& c : s.corners_px) quad.emplace_back(c);
  d.area_px2 = cv::contourArea(quad);
  const cv::Rect box = s.bbox();
  d.bbox_x_px = box.x;
  d.bbox_y_px = box.y;
  d.bbox_width_px = box.width;
  d.bbox_height_px = box.height;
  d.match_index = -1;
  return d;
}

ptzstereo::detection_2d_t toMessage(const PatchObject& o, int side) {
  ptzstereo::detection_2d_t d{};
  d.class_name = o.class_name;
  d.centroid_x_px = o.pixel[side].x;
  d.centroid_y_px = o.pixel[side].y;
  d.area_px2 = o.box[side].area();
  d.bbox_x_px = o.box[side].x;
  d.bbox_y_px = o.box[side].y;
  d.bbox_width_px = o.box[side].width;
  d.bbox_height_px = o.box[side].height;
  d.match_index = -1;
  return d;
}

ptzstereo::object_3d_t toMessage(const PatchObject& o, int left_index, int right_index) {
  ptzstereo::object_3d_t obj{};
  obj.class_name = o.class_name;
  for (int r = 0; r < 3; ++r) obj.position_m[r] = o.position_m[r];
  copyMatrix(o.covariance_m2, obj.covariance_m2);
  obj.left_index = left_index;
  obj.right_index = right_index;
  obj.radius_m = o.radius_m;
  obj.orientation_wxyz[0] = 1;
  return obj;
}

ptzstereo::object_3d_t toMessage(const MarkerObject& o, int left_index, int right_index) {
  ptzstereo::object_3d_t obj{};
  obj.class_name = o.name;
  for (int r = 0; r < 3; ++r) obj.position_m[r] = o.pose.position_head_m[r];
  copyMatrix(o.pose.covariance.bottomRightCorner<3, 3>(), obj.covariance_m2);
  obj.left_index = left_index;
  obj.right_index = right_index;
  obj.radius_m = o.radius_m;
  obj.has_orientation = true;
  copyRotation(Eigen::Quaterniond(o.pose.rotation_head_object).normalized(),
               o.pose.covariance.topLeftCorner<3, 3>(), obj.orientation_wxyz,
               obj.orientation_covariance_rad2);
  return obj;
}

ptzstereo::detection_2d_t toMessage(const Region& r, const DetectorParams& dp) {
  ptzstereo::detection_2d_t d{};
  d.class_name = dp.classes[static_cast<size_t>(r.class_index)].name;
  d.centroid_x_px = r.centroid_px.x;
  d.centroid_y_px = r.centroid_px.y;
  d.area_px2 = r.area_px2;
  d.bbox_x_px = r.bbox.x;
  d.bbox_y_px = r.bbox.y;
  d.bbox_width_px = r.bbox.width;
  d.bbox_height_px = r.bbox.height;
  d.shape_distance = r.shape_distance;
  d.match_index = -1;
  return d;
}

ptzstereo::object_3d_t toMessage(const StereoObject& o, const std::string& class_name,
                                 double radius_m, const BoxYaw& yaw) {
  ptzstereo::object_3d_t obj{};
  obj.class_name = class_name;
  for (int r = 0; r < 3; ++r) {
    obj.position_m[r] = o.position_head_m[r];
    for (int c = 0; c < 3; ++c) obj.covariance_m2[r * 3 + c] = o.covariance_m2(r, c);
  }
  obj.left_index = o.left;
  obj.right_index = o.right;
  obj.radius_m = radius_m;
  obj.has_orientation = yaw.ok;
  obj.orientation_wxyz[0] = 1;
  if (yaw.ok) {
    copyYaw(yaw.yaw_rad, yaw.variance_rad2, obj.orientation_wxyz, obj.orientation_covariance_rad2);
  }
  return obj;
}

ptzstereo::object_track_t toMessage(const Track& t, double now_s, const TrackerParams& p) {
  ptzstereo::object_track_t m{};
  m.id = t.id;
  m.class_name = t.class_name;
  m.state = t.state == TrackState::kTentative   ? ptzstereo::object_track_t::STATE_TENTATIVE
            : t.state == TrackState::kConfirmed ? ptzstereo::object_track_t::STATE_CONFIRMED
                                                : ptzstereo::object_track_t::STATE_COASTING;
  for (int i = 0; i < 3; ++i) {
    m.position_m[i] = t.position()[i];
    m.velocity_m_s[i] = t.velocity()[i];
    m.acceleration_m_s2[i] = t.acceleration()[i];
  }
  copyMatrix(t.positionCovariance(), m.position_covariance_m2);
  copyMatrix(t.velocityCovariance(), m.velocity_covariance_m2_s2);
  m.radius_m = t.radius_m;
  m.age_s = now_s - t.first_s;
  m.since_update_s = now_s - t.last_update_s;
  m.object_index = t.object_index;
  m.untrusted_updates = t.untrusted_updates;
  m.has_orientation = t.has_yaw;
  m.orientation_wxyz[0] = 1;
  if (t.rotation.ok) {
    m.has_orientation = true;
    copyRotation(t.rotation.rotationAt(now_s), t.rotation.covarianceAt(now_s, p.rotation),
                 m.orientation_wxyz, m.orientation_covariance_rad2);
  } else if (t.has_yaw) {
    copyYaw(t.yaw_rad, t.yawVarianceAt(now_s, p.yaw_psd_rad2_s), m.orientation_wxyz,
            m.orientation_covariance_rad2);
  }
  return m;
}

ptzstereo::object_3d_t viewObject(const Track& t) {
  ptzstereo::object_3d_t obj{};
  obj.class_name = t.class_name;
  for (int i = 0; i < 3; ++i) obj.position_m[i] = t.position()[i];
  copyMatrix(t.positionCovariance(), obj.covariance_m2);
  obj.left_index = t.view_side == Side::kLeft ? t.view_region_index : -1;
  obj.right_index = t.view_side == Side::kRight ? t.view_region_index : -1;
  obj.radius_m = t.radius_m;
  obj.orientation_wxyz[0] = 1;
  return obj;
}

}  // namespace ptz::perception
