#include "sim/scene/scene.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>

#include "common/markers.hpp"
#include "common/rig.hpp"
#include "sim/scene/pictures.hpp"

namespace ptz::sim {

Trajectory::Type Trajectory::parseType(const std::string& name, const std::string& where) {
  if (name == "static") return Type::kStatic;
  if (name == "line") return Type::kLine;
  if (name == "circle") return Type::kCircle;
  if (name == "figure_eight") return Type::kFigureEight;
  if (name == "random_walk") return Type::kRandomWalk;
  if (name == "arc") return Type::kArc;
  throw ConfigError(fieldPath(where, "trajectory") +
                    ": must be one of static, line, circle, figure_eight, random_walk, arc, got '" +
                    name + "'");
}

Eigen::Vector3d Trajectory::position(double t) const {
  const double w = 2 * M_PI / period_s;
  const double a = w * t + phase_rad;
  const Eigen::Vector3d& A = amplitude_m;
  switch (type) {
    case Type::kStatic:
      return centre_m;
    case Type::kLine: {
      // Back and forth between centre - A and centre + A, at constant speed.
      const double s = std::asin(std::sin(a)) * 2 / M_PI;
      return centre_m + s * A;
    }
    case Type::kCircle:
      return centre_m +
             Eigen::Vector3d(A.x() * std::cos(a), A.y() * std::sin(a), A.z() * std::sin(a));
    case Type::kFigureEight:
      return centre_m +
             Eigen::Vector3d(A.x() * std::sin(a), A.y() * std::sin(2 * a), A.z() * std::sin(2 * a));
    case Type::kArc: {
      const double azimuth = arc_rad * std::sin(a);
      return centre_m + Eigen::Vector3d(A.x() * std::sin(azimuth), A.y() * std::sin(2 * a),
                                        A.x() * std::cos(azimuth));
    }
    case Type::kRandomWalk: {
      // A band-limited random path: a seeded sum of sinusoids, smooth and within +-A.
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> freq(0.3, 1.5), phase(0, 2 * M_PI);
      Eigen::Vector3d p = centre_m;
      constexpr int kTerms = 4;
      for (int axis = 0; axis < 3; ++axis) {
        double sum = 0;
        for (int k = 0; k < kTerms; ++k) sum += std::sin(freq(rng) * w * t + phase(rng));
        p[axis] += A[axis] * sum / kTerms;
      }
      return p;
    }
  }
  return centre_m;
}

Eigen::Vector3d Trajectory::velocity(double t) const {
  constexpr double h = 1e-4;
  return (position(t + h) - position(t - h)) / (2 * h);
}

double SceneObject::boundingRadius() const {
  switch (shape) {
    case Shape::kSphere:
      return radius_m;
    case Shape::kBox:
      return half_extents_m.norm();
    case Shape::kPerson:
      return std::hypot(height_m / 2, height_m / 4);
  }
  return 0;
}

double SceneObject::yaw(double t_s) const {
  return shape == Shape::kSphere ? 0.0 : yaw_rad + yaw_rate_rad_s * t_s;
}

Eigen::Matrix3d SceneObject::rotationHeadObject(double t_s) const {
  if (shape == Shape::kSphere) return Eigen::Matrix3d::Identity();
  return (Eigen::AngleAxisd(yaw(t_s), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

bool SceneObject::hasMarkers() const {
  return std::any_of(tags.begin(), tags.end(), [](const SceneTag& t) { return t.isMarker(); });
}

double SceneObject::stride(double t_s) const {
  if (shape != Shape::kPerson) return 0;
  // A step as long as the walk is fast, up to a walker's at 1.5 m/s; a gait cycle of 1.1 s.
  constexpr double kLongStride = 0.12, kBriskWalk_m_s = 1.5, kGaitCycle_s = 1.1;
  const double speed_m_s = trajectory.velocity(t_s).norm();
  return kLongStride * std::min(1.0, speed_m_s / kBriskWalk_m_s) *
         std::sin(2 * M_PI * t_s / kGaitCycle_s);
}

std::vector<Eigen::Vector3d> Chessboard::innerCorners() const {
  std::vector<Eigen::Vector3d> corners;
  for (int r = 0; r < inner_rows; ++r) {
    for (int c = 0; c < inner_cols; ++c) {
      const Eigen::Vector3d b((c - (inner_cols - 1) / 2.0) * square_m,
                              (r - (inner_rows - 1) / 2.0) * square_m, 0);
      corners.push_back(centre_head_m + rotation_head_board * b);
    }
  }
  return corners;
}

namespace {

Eigen::Vector3d vec3(const cv::FileNode& n, const std::string& field, const std::string& where,
                     const Eigen::Vector3d& fallback, const Range& range = {}) {
  if (n[field].empty()) return fallback;
  auto v = readNumbers(n, field, 3, where, range);
  return {v[0], v[1], v[2]};
}

unsigned readSeed(const cv::FileNode& n, const std::string& field, const std::string& where,
                  unsigned fallback) {
  if (n[field].empty()) return fallback;
  return static_cast<unsigned>(readInt(n, field, where, Range::atLeast(0)));
}

// The fields an object may have (besides those of its shape).
const std::vector<std::string> kObjectFields = {"name",     "class",      "shape",    "color_bgr",
                                                "textured", "trajectory", "centre_m", "amplitude_m",
                                                "period_s", "phase_rad",  "seed",     "arc_rad"};

// Where a print lies on its box: its z axis along a box axis, into the box, its centre on that
// face, and all of it inside the face (height_m: the print's extent along its y axis).
void checkOnFace(const SceneTag& tag, double height_m, const Eigen::Vector3d& half_m,
                 const std::string& w) {
  const Eigen::Vector3d z = tag.rotation_object_tag.col(2);
  int axis = 0;
  z.cwiseAbs().maxCoeff(&axis);
  const double inward = z[axis];
  if (std::abs(std::abs(inward) - 1) > 1e-6 ||
      std::abs(tag.centre_m[axis] + (inward > 0 ? half_m[axis] : -half_m[axis])) > 1e-6) {
    throw ConfigError(w +
                      ": the print is on no face of the box (its z axis, into the box, must be "
                      "a box axis and its centre_m on that face)");
  }
  for (int k = 0; k < 3; ++k) {
    const double reach = std::abs(tag.centre_m[k]) +
                         tag.size_m / 2 * std::abs(tag.rotation_object_tag(k, 0)) +
                         height_m / 2 * std::abs(tag.rotation_object_tag(k, 1));
    if (k != axis && reach > half_m[k] + 1e-9) {
      throw ConfigError(w + ": the print reaches beyond its face");
    }
  }
}

// A box's tags (`tags`: fiducial markers) and pictures (`prints`: `picture: face`, drawn), each
// on one of its faces and inside it.
std::vector<SceneTag> readTags(const cv::FileNode& n, const Eigen::Vector3d& half_m,
                               const std::string& where) {
  std::vector<SceneTag> tags;
  for (const std::string list_name : {"tags", "prints"}) {
    if (n[list_name].empty()) continue;
    const cv::FileNode list = n[list_name];
    if (!list.isSeq()) throw ConfigError(fieldPath(where, list_name) + ": must be a list");
    const bool markers = list_name == "tags";
    int i = 0;
    for (const auto& t : list) {
      const std::string w = where + "." + list_name + "[" + std::to_string(i++) + "]";
      SceneTag tag;
      if (markers) {
        checkFields(t, {"family", "id", "size_m", "centre_m", "yaw_deg", "pitch_deg"}, w);
        if (!t["family"].empty()) tag.family = readString(t, "family", w);
        tag.id = readInt(t, "id", w, Range::atLeast(0));
        std::string why;
        if (!markerCells(tag.family, tag.id, &tag.cells, &why)) throw ConfigError(w + ": " + why);
      } else {
        checkFields(t, {"picture", "size_m", "centre_m", "yaw_deg", "pitch_deg"}, w);
        tag.family.clear();
        tag.id = -1;
        const std::string picture = readString(t, "picture", w);
        if (picture != "face") {
          throw ConfigError(fieldPath(w, "picture") + ": must be face, got '" + picture + "'");
        }
        tag.picture = facePicture(256);
      }
      tag.size_m = readDouble(t, "size_m", w, Range::above(0));
      tag.centre_m = vec3(t, "centre_m", w, Eigen::Vector3d::Zero());
      tag.rotation_object_tag =
          tagRotation(readDouble(t, "yaw_deg", w, 0, Range::between(-360, 360)),
                      readDouble(t, "pitch_deg", w, 0, Range::between(-360, 360)));
      const double height_m =
          markers ? tag.size_m : tag.size_m * tag.picture.rows / tag.picture.cols;
      checkOnFace(tag, height_m, half_m, w);
      tags.push_back(tag);
    }
  }
  return tags;
}

SceneObject readObject(const cv::FileNode& n, const std::string& w) {
  SceneObject o;
  if (!n.isMap()) checkFields(n, {}, w);  // throws "must be a map"; the shape decides the fields
  const std::string shape = readString(n, "shape", w);
  std::vector<std::string> known = kObjectFields;
  if (shape == "sphere") {
    known.push_back("radius_m");
  } else if (shape == "box") {
    known.insert(known.end(), {"half_extents_m", "yaw_rad", "yaw_rate_rad_s", "pitch_rad",
                               "roll_rad", "tags", "prints"});
  } else if (shape == "person") {
    known.insert(known.end(), {"height_m", "yaw_rad"});
  } else {
    throw ConfigError(fieldPath(w, "shape") + ": must be sphere, box or person, got '" + shape +
                      "'");
  }
  checkFields(n, known, w);
  o.name = readString(n, "name", w);
  o.class_name = readString(n, "class", w);
  if (shape == "sphere") {
    o.shape = SceneObject::Shape::kSphere;
    o.radius_m = readDouble(n, "radius_m", w, Range::above(0));
  } else if (shape == "person") {
    o.shape = SceneObject::Shape::kPerson;
    o.height_m = readDouble(n, "height_m", w, o.height_m, Range::between(0.2, 3.0));
    o.yaw_rad = readDouble(n, "yaw_rad", w, 0.0, Range::between(-M_PI, M_PI));
  } else {
    o.shape = SceneObject::Shape::kBox;
    o.half_extents_m = vec3(n, "half_extents_m", w, Eigen::Vector3d::Zero(), Range::above(0));
    if ((o.half_extents_m.array() <= 0).any()) {
      throw ConfigError(w + ": missing field 'half_extents_m'");
    }
    o.yaw_rad = readDouble(n, "yaw_rad", w, 0.0);
    o.yaw_rate_rad_s = readDouble(n, "yaw_rate_rad_s", w, 0.0, Range::between(-20, 20));
    o.pitch_rad = readDouble(n, "pitch_rad", w, 0.0, Range::between(-M_PI, M_PI));
    o.roll_rad = readDouble(n, "roll_rad", w, 0.0, Range::between(-M_PI, M_PI));
    o.tags = readTags(n, o.half_extents_m, w);
  }
  const auto bgr = readNumbers(n, "color_bgr", 3, w, Range::between(0, 255));
  for (int k = 0; k < 3; ++k) o.color_bgr[k] = static_cast<uchar>(bgr[k]);
  o.textured = !n["textured"].empty() && readInt(n, "textured", w, Range::between(0, 1)) != 0;
  Trajectory& t = o.trajectory;
  t.type =
      Trajectory::parseType(n["trajectory"].empty() ? "static" : readString(n, "trajectory", w), w);
  t.centre_m = vec3(n, "centre_m", w, t.centre_m);
  t.amplitude_m = vec3(n, "amplitude_m", w, t.amplitude_m);
  t.period_s = readDouble(n, "period_s", w, t.period_s, Range::above(0));
  t.phase_rad = readDouble(n, "phase_rad", w, 0.0);
  t.seed = readSeed(n, "seed", w, t.seed);
  t.arc_rad = readDouble(n, "arc_rad", w, t.arc_rad, Range::between(0, 2 * M_PI));
  return o;
}

// The scene section's `camera` map (absent: an instant).
Shutter readShutter(const cv::FileNode& n, const std::string& where) {
  Shutter shutter;
  if (n.empty()) return shutter;
  const std::string w = fieldPath(where, "camera");
  checkFields(n, {"exposure_s", "blur_samples"}, w);
  shutter.exposure_s = readDouble(n, "exposure_s", w, 0.0, Range::between(0, 0.2));
  shutter.blur_samples =
      n["blur_samples"].empty() ? 5 : readInt(n, "blur_samples", w, Range::between(2, 16));
  return shutter;
}

}  // namespace

Scene Scene::fromConfig(const cv::FileNode& scene_node, const cv::FileNode& objects,
                        const cv::FileNode& board, const std::string& where,
                        const std::string& base_dir) {
  Scene scene;
  if (!scene_node.empty()) {
    const std::string w = where + ", scene";
    checkFields(scene_node,
                {"backdrop_distance_m", "floor_height_m", "texture_m_per_texel", "texture_seed",
                 "light", "posters", "camera"},
                w);
    scene.backdrop_distance_m =
        readDouble(scene_node, "backdrop_distance_m", w, 8.0, Range::above(0.5));
    scene.floor_height_m = readDouble(scene_node, "floor_height_m", w, 1.4);
    scene.texture_m_per_texel =
        readDouble(scene_node, "texture_m_per_texel", w, 0.01, Range::above(0));
    scene.texture_seed = readSeed(scene_node, "texture_seed", w, scene.texture_seed);
    scene.light = Light::fromConfig(scene_node["light"], w);
    scene.posters = readPosters(scene_node["posters"], w, base_dir);
    scene.camera = readShutter(scene_node["camera"], w);
  }
  if (!objects.empty()) {
    if (!objects.isSeq()) throw ConfigError(where + ", objects: must be a list");
    int i = 0;
    for (const auto& n : objects) {
      scene.objects.push_back(readObject(n, where + ", objects[" + std::to_string(i++) + "]"));
    }
  }
  if (!board.empty()) {
    const std::string w = where + ", chessboard";
    checkFields(board, {"inner_cols", "inner_rows", "square_m", "centre_m", "rotation_vector"}, w);
    Chessboard& b = scene.chessboard;
    b.present = true;
    b.inner_cols = readInt(board, "inner_cols", w, Range::between(2, 1000));
    b.inner_rows = readInt(board, "inner_rows", w, Range::between(2, 1000));
    b.square_m = readDouble(board, "square_m", w, Range::above(0));
    b.centre_head_m = vec3(board, "centre_m", w, b.centre_head_m);
    const Eigen::Vector3d rvec = vec3(board, "rotation_vector", w, Eigen::Vector3d::Zero());
    if (rvec.norm() > 0) b.rotation_head_board = Eigen::AngleAxisd(rvec.norm(), rvec.normalized());
  }
  return scene;
}

}  // namespace ptz::sim
