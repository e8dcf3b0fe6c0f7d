#include "perception/markers/marker_pose.hpp"

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include <cmath>
#include <map>

#include "perception/detection/stereo.hpp"

namespace ptz::perception {
namespace {

Eigen::Matrix3d expRotation(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

// Residuals (pixels) of every corner's sightings for the pose (R, t).
Eigen::VectorXd residuals(const std::vector<MarkerCorner>& corners, const CameraView* views[2],
                          const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  std::vector<double> r;
  for (const auto& c : corners) {
    const Eigen::Vector3d p = R * c.model_m + t;
    for (int s = 0; s < 2; ++s) {
      if (!c.seen[s]) continue;
      const Eigen::Vector2d e = views[s]->project(p) - c.pixel[s];
      r.push_back(e.x());
      r.push_back(e.y());
    }
  }
  return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
}

}  // namespace

bool estimateMarkerPose(const std::vector<MarkerCorner>& corners, const CameraView& left,
                        const CameraView& right, const MarkerPoseParams& params, MarkerPose* pose,
                        std::string* why) {
  const CameraView* views[2] = {&left, &right};
  std::vector<Eigen::Vector3d> model, head;
  for (const auto& c : corners) {
    Eigen::Vector3d p;
    if (c.seen[0] && c.seen[1] && triangulate(left, right, c.pixel[0], c.pixel[1], &p)) {
      model.push_back(c.model_m);
      head.push_back(p);
    }
  }
  if (model.size() < 3) {
    *why = "few_corners: " + std::to_string(model.size()) + " corners in both views, 3 needed";
    return false;
  }
  Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(model.size())), dst(3, src.cols());
  for (Eigen::Index i = 0; i < src.cols(); ++i) {
    src.col(i) = model[static_cast<size_t>(i)];
    dst.col(i) = head[static_cast<size_t>(i)];
  }
  // Corners in a line fix no rotation about it.
  const Eigen::Matrix3Xd centred = src.colwise() - src.rowwise().mean();
  const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(centred);
  if (svd.singularValues()(1) < 1e-6 * std::max(1e-9, svd.singularValues()(0))) {
    *why = "collinear: the corners are in a line";
    return false;
  }
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, false);
  Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  Eigen::Vector3d t = T.topRightCorner<3, 1>();

  // Levenberg-Marquardt on the reprojection of every sighting, the rotation perturbed on the left
  // (head frame) so the covariance is the messages' rotation-vector error.
  Eigen::VectorXd r = residuals(corners, views, R, t);
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  Eigen::MatrixXd J(r.size(), 6);
  auto jacobian = [&](const Eigen::Matrix3d& R0, const Eigen::Vector3d& t0) {
    constexpr double kRotStep = 1e-6, kPosStep = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Eigen::Vector3d w = Eigen::Vector3d::Zero(), d = Eigen::Vector3d::Zero();
      const double h = k < 3 ? kRotStep : kPosStep;
      (k < 3 ? w : d)[k % 3] = h;
      const Eigen::VectorXd plus = residuals(corners, views, expRotation(w) * R0, t0 + d);
      const Eigen::VectorXd minus = residuals(corners, views, expRotation(-w) * R0, t0 - d);
      J.col(k) = (plus - minus) / (2 * h);
    }
  };
  for (int it = 0; it < 20; ++it) {
    jacobian(R, t);
    if (!J.allFinite() || !r.allFinite()) {
      *why = "not_finite: a corner behind a camera";
      return false;
    }
    const Eigen::Matrix<double, 6, 6> H = J.transpose() * J;
    const Eigen::Matrix<double, 6, 1> g = J.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 8 && !improved; ++tries) {
      Eigen::Matrix<double, 6, 6> A = H;
      A.diagonal() *= 1 + lambda;
      const Eigen::Matrix<double, 6, 1> step = A.ldlt().solve(-g);
      const Eigen::Matrix3d R1 = expRotation(step.head<3>()) * R;
      const Eigen::Vector3d t1 = t + step.tail<3>();
      const Eigen::VectorXd r1 = residuals(corners, views, R1, t1);
      if (r1.allFinite() && r1.squaredNorm() < cost) {
        const bool converged = cost - r1.squaredNorm() < 1e-10 * (1 + cost);
        R = R1, t = t1, r = r1, cost = r.squaredNorm();
        lambda = std::max(1e-7, lambda / 10);
        improved = true;
        if (converged) it = 1000;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  jacobian(R, t);
  const Eigen::Index m = r.size();
  pose->rms_px = std::sqrt(cost / static_cast<double>(m));
  if (!(pose->rms_px <= params.max_rms_px)) {
    *why = "reprojection: RMS " + std::to_string(pose->rms_px) + " px";
    return false;
  }
  // A corner off by more than a pixel is not noise: a tag partly hidden (its corner found on the
  // hider's edge) or two tags taken for one; the fit spreads it over the others, so test each.
  double worst_px = 0;
  for (Eigen::Index i = 0; i + 1 < r.size(); i += 2) {
    worst_px = std::max(worst_px, std::hypot(r[i], r[i + 1]));
  }
  if (!(worst_px <= params.max_corner_px)) {
    *why = "corner_residual: a corner " + std::to_string(worst_px) + " px off the fit";
    return false;
  }
  const double range_m =
      std::min((t - left.position_head_m).norm(), (t - right.position_head_m).norm());
  if (range_m < params.min_range_m || range_m > params.max_range_m) {
    *why = "range: " + std::to_string(range_m) + " m";
    return false;
  }
  // The noise: the floor, or what the residuals say when they say more.
  const double dof = static_cast<double>(std::max<Eigen::Index>(1, m - 6));
  const double sigma2 = std::max(params.corner_sigma_px * params.corner_sigma_px, cost / dof);
  const Eigen::Matrix<double, 6, 6> H = J.transpose() * J;
  Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(H);
  if (!lu.isInvertible()) {
    *why = "unobservable: the fit's information is singular";
    return false;
  }
  pose->covariance = sigma2 * lu.inverse();
  pose->rotation_head_object = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  pose->position_head_m = t;
  pose->stereo_corners = static_cast<int>(model.size());
  return true;
}

std::vector<MarkerObject> markerObjects(const std::vector<MarkerClass>& classes,
                                        const std::vector<MarkerSighting>& left,
                                        const std::vector<MarkerSighting>& right,
                                        const CameraView& left_view, const CameraView& right_view,
                                        const MarkerPoseParams& params,
                                        std::vector<std::string>* failed) {
  const std::vector<MarkerSighting>* views[2] = {&left, &right};
  // Object name -> its sightings in each view; ids seen twice in a view.
  std::map<std::string, MarkerObject> objects;
  std::map<std::string, bool> twice;
  for (int s = 0; s < 2; ++s) {
    std::map<std::pair<int, int>, int> seen;  // (class, id) -> count in this view
    for (size_t i = 0; i < views[s]->size(); ++i) {
      const MarkerSighting& m = (*views[s])[i];
      if (m.class_index < 0 || static_cast<size_t>(m.class_index) >= classes.size()) continue;
      const MarkerClass& c = classes[static_cast<size_t>(m.class_index)];
      const std::string name = c.objectName(m.id);
      if (name.empty()) continue;
      if (++seen[{m.class_index, m.id}] > 1) twice[name] = true;
      MarkerObject& o = objects[name];
      o.class_index = m.class_index;
      o.name = name;
      o.sightings[s].push_back(static_cast<int>(i));
    }
  }
  std::vector<MarkerObject> out;
  for (auto& [name, o] : objects) {
    if (twice.count(name)) {
      if (failed) failed->push_back("tag_seen_twice");
      continue;
    }
    const MarkerClass& c = classes[static_cast<size_t>(o.class_index)];
    // Corners by (id, k): both views' sightings of one tag meet there.
    std::map<std::pair<int, int>, MarkerCorner> corners;
    for (int s = 0; s < 2; ++s) {
      for (int i : o.sightings[s]) {
        const MarkerSighting& m = (*views[s])[static_cast<size_t>(i)];
        const std::vector<Eigen::Vector3d> model = c.corners(m.id);
        for (int k = 0; k < 4; ++k) {
          MarkerCorner& mc = corners[{m.id, k}];
          mc.model_m = model[static_cast<size_t>(k)];
          mc.seen[s] = true;
          const cv::Point2d& p = m.corners_px[static_cast<size_t>(k)];
          mc.pixel[s] = {p.x, p.y};
        }
      }
    }
    std::vector<MarkerCorner> list;
    for (const auto& kv : corners) list.push_back(kv.second);
    std::string why;
    if (!estimateMarkerPose(list, left_view, right_view, params, &o.pose, &why)) {
      if (failed) failed->push_back(why.substr(0, why.find(':')));
      continue;
    }
    o.radius_m = c.radiusM();
    out.push_back(o);
  }
  return out;
}

}  // namespace ptz::perception
