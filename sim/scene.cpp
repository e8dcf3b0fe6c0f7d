#include "sim/scene.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <random>

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
  return shape == Shape::kSphere ? radius_m : half_extents_m.norm();
}

double SceneObject::yaw(double t_s) const {
  return shape == Shape::kBox ? yaw_rad + yaw_rate_rad_s * t_s : 0.0;
}

Eigen::Matrix3d SceneObject::rotationHeadObject(double t_s) const {
  return Eigen::AngleAxisd(yaw(t_s), Eigen::Vector3d::UnitY()).toRotationMatrix();
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

SceneObject readObject(const cv::FileNode& n, const std::string& w) {
  SceneObject o;
  if (!n.isMap()) checkFields(n, {}, w);  // throws "must be a map"; the shape decides the fields
  const std::string shape = readString(n, "shape", w);
  std::vector<std::string> known = kObjectFields;
  if (shape == "sphere") {
    known.push_back("radius_m");
  } else if (shape == "box") {
    known.insert(known.end(), {"half_extents_m", "yaw_rad", "yaw_rate_rad_s"});
  } else {
    throw ConfigError(fieldPath(w, "shape") + ": must be sphere or box, got '" + shape + "'");
  }
  checkFields(n, known, w);
  o.name = readString(n, "name", w);
  o.class_name = readString(n, "class", w);
  if (shape == "sphere") {
    o.shape = SceneObject::Shape::kSphere;
    o.radius_m = readDouble(n, "radius_m", w, Range::above(0));
  } else {
    o.shape = SceneObject::Shape::kBox;
    o.half_extents_m = vec3(n, "half_extents_m", w, Eigen::Vector3d::Zero(), Range::above(0));
    if ((o.half_extents_m.array() <= 0).any()) {
      throw ConfigError(w + ": missing field 'half_extents_m'");
    }
    o.yaw_rad = readDouble(n, "yaw_rad", w, 0.0);
    o.yaw_rate_rad_s = readDouble(n, "yaw_rate_rad_s", w, 0.0, Range::between(-20, 20));
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

}  // namespace

Scene Scene::fromConfig(const cv::FileNode& scene_node, const cv::FileNode& objects,
                        const cv::FileNode& board, const std::string& where) {
  Scene scene;
  if (!scene_node.empty()) {
    const std::string w = where + ", scene";
    checkFields(scene_node,
                {"backdrop_distance_m", "floor_height_m", "texture_m_per_texel", "texture_seed"},
                w);
    scene.backdrop_distance_m =
        readDouble(scene_node, "backdrop_distance_m", w, 8.0, Range::above(0.5));
    scene.floor_height_m = readDouble(scene_node, "floor_height_m", w, 1.4);
    scene.texture_m_per_texel =
        readDouble(scene_node, "texture_m_per_texel", w, 0.01, Range::above(0));
    scene.texture_seed = readSeed(scene_node, "texture_seed", w, scene.texture_seed);
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
