#include "sim/state_messages.hpp"

namespace ptz::sim {
namespace {

ptzstereo::ptz_head_state_t headState(const PtzPlant& plant, Side side) {
  const PtzPose p = plant.pose(side);
  const PtzPose r = plant.rate(side);
  ptzstereo::ptz_head_state_t s{};
  s.pan_rad = p.pan_rad;
  s.tilt_rad = p.tilt_rad;
  s.zoom = p.zoom;
  s.pan_rate_rad_s = r.pan_rad;
  s.tilt_rate_rad_s = r.tilt_rad;
  s.zoom_rate_per_s = r.zoom;
  s.at_limit = plant.atLimit(side);
  return s;
}

ptzstereo::camera_model_t cameraModel(const CameraView& v) {
  ptzstereo::camera_model_t m{};
  m.width = v.width;
  m.height = v.height;
  m.fx_px = v.intrinsics.fx;
  m.fy_px = v.intrinsics.fy;
  m.cx_px = v.intrinsics.cx;
  m.cy_px = v.intrinsics.cy;
  for (int i = 0; i < 5; ++i) m.distortion[i] = v.intrinsics.distortion[i];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.rotation_head_camera[r * 3 + c] = v.rotation_head_camera(r, c);
    m.position_head_m[r] = v.position_head_m[r];
  }
  return m;
}

}  // namespace

ptzstereo::ptz_state_t makeStateMessage(const PtzPlant& plant, int64_t utime) {
  ptzstereo::ptz_state_t msg{};
  msg.utime = utime;
  msg.left = headState(plant, Side::kLeft);
  msg.right = headState(plant, Side::kRight);
  return msg;
}

ptzstereo::sim_truth_t makeTruthMessage(const Simulator& sim, const SimFrame& frame,
                                        int64_t utime) {
  ptzstereo::sim_truth_t msg{};
  msg.utime = utime;
  msg.frame_seq = frame.index;
  msg.left_head = headState(sim.plant(), Side::kLeft);
  msg.right_head = headState(sim.plant(), Side::kRight);
  msg.left_camera = cameraModel(sim.rig().view(Side::kLeft, frame.left_pose));
  msg.right_camera = cameraModel(sim.rig().view(Side::kRight, frame.right_pose));
  for (const auto& o : sim.scene().objects) {
    ptzstereo::sim_object_truth_t t{};
    t.name = o.name;
    t.class_name = o.class_name;
    t.shape = o.shape == SceneObject::Shape::kSphere   ? "sphere"
              : o.shape == SceneObject::Shape::kPerson ? "person"
              : o.hasMarkers()                         ? "tagged_box"
                                                       : "box";
    const Eigen::Vector3d p = o.trajectory.position(frame.t_s);
    const Eigen::Vector3d v = o.trajectory.velocity(frame.t_s);
    for (int k = 0; k < 3; ++k) {
      t.position_m[k] = p[k];
      t.velocity_m_s[k] = v[k];
    }
    t.radius_m = o.shape == SceneObject::Shape::kSphere   ? o.radius_m
                 : o.shape == SceneObject::Shape::kPerson ? o.height_m / 2
                                                          : o.half_extents_m.maxCoeff();
    const Eigen::Quaterniond q(o.rotationHeadObject(frame.t_s));
    t.orientation_wxyz[0] = q.w();
    t.orientation_wxyz[1] = q.x();
    t.orientation_wxyz[2] = q.y();
    t.orientation_wxyz[3] = q.z();
    msg.objects.push_back(t);
  }
  msg.num_objects = static_cast<int32_t>(msg.objects.size());
  setVisibility(frame, &msg);
  return msg;
}

void setVisibility(const SimFrame& rendered, ptzstereo::sim_truth_t* truth) {
  for (size_t camera = 0; camera < 2; ++camera) {
    const std::vector<double>& fraction = rendered.visible_fraction[camera];
    for (size_t i = 0; i < truth->objects.size(); ++i) {
      truth->objects[i].visible_fraction[camera] = i < fraction.size() ? fraction[i] : 0.0;
    }
  }
}

}  // namespace ptz::sim
