// The simulated world in the head frame: a textured backdrop with posters on it and a floor,
// coloured objects on trajectories, and an optional chessboard target for calibration; its light
// and the cameras' shutter.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "common/config.hpp"
#include "sim/scene/light.hpp"
#include "sim/scene/posters.hpp"

namespace ptz::sim {

struct Trajectory {
  enum class Type { kStatic, kLine, kCircle, kFigureEight, kRandomWalk, kArc };
  Type type = Type::kStatic;
  Eigen::Vector3d centre_m = Eigen::Vector3d(0, 0, 3);
  // Half-extent of the motion along x, y, z, m.
  Eigen::Vector3d amplitude_m = Eigen::Vector3d::Zero();
  double period_s = 20.0;
  double phase_rad = 0.0;
  unsigned seed = 1;  // random_walk only
  // arc: around centre_m at the radius amplitude_m.x, the azimuth (from +z towards +x) swinging
  // between -arc_rad and +arc_rad; amplitude_m.y bobs it up and down.
  double arc_rad = M_PI / 2;

  Eigen::Vector3d position(double t_s) const;
  Eigen::Vector3d velocity(double t_s) const;
  static Type parseType(const std::string& name, const std::string& where);
};

// A fiducial marker printed on a box's face (common/markers.hpp: the family, the tag's frame), or
// a picture printed there (a face; cells empty, family empty).
struct SceneTag {
  std::string family = "apriltag_36h11";
  int id = 0;
  double size_m = 0.1;  // edge of the black square; a picture's width
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();  // in the box's frame, on a face
  Eigen::Matrix3d rotation_object_tag = Eigen::Matrix3d::Identity();
  cv::Mat cells;    // markerCells: 0 black, 255 white, the black border included
  cv::Mat picture;  // a print's BGR reflectance (255: white), its x along the tag frame's x
  bool isMarker() const { return !cells.empty(); }
};

struct SceneObject {
  // person: a cut-out figure (sim/pictures.hpp) upright in its x-y plane, facing -z (the cameras at
  // yaw 0), its centre at half its height; it steps with its speed.
  enum class Shape { kSphere, kBox, kPerson };
  std::string name;
  std::string class_name;
  Shape shape = Shape::kSphere;
  double radius_m = 0.1;                                     // sphere
  Eigen::Vector3d half_extents_m = Eigen::Vector3d::Zero();  // box
  double height_m = 1.75;                                    // person
  double yaw_rad = 0.0;         // box and person, about the head's y axis
  double yaw_rate_rad_s = 0.0;  // box: its yaw turns at this rate
  // Box: then tilted about its x axis and rolled about its z axis (fixed).
  double pitch_rad = 0.0, roll_rad = 0.0;
  std::vector<SceneTag> tags;  // box: markers and pictures on its faces
  cv::Vec3b color_bgr{0, 0, 220};
  // The colour modulated by the backdrop's texture on the surface: gives dense stereo something
  // to match (plain objects only shade smoothly).
  bool textured = false;
  Trajectory trajectory;

  double boundingRadius() const;
  // A box's or person's yaw at t_s (yaw_rad + yaw_rate_rad_s t_s), 0 for a sphere; and the
  // rotation head <- object, Ry(yaw) Rx(pitch) Rz(roll) (identity for a sphere).
  double yaw(double t_s) const;
  Eigen::Matrix3d rotationHeadObject(double t_s) const;
  // Whether a box carries a fiducial marker (its faces are told apart).
  bool hasMarkers() const;
  // A person's step at t_s: the feet's distance apart as a share of its height (0: standing).
  double stride(double t_s) const;
};

struct Chessboard {
  bool present = false;
  int inner_cols = 9;
  int inner_rows = 6;
  double square_m = 0.05;
  // Board frame: x along the columns, y along the rows, z into the board.
  Eigen::Matrix3d rotation_head_board = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre_head_m = Eigen::Vector3d(0, 0, 2);

  // Head-frame positions of the inner corners, row by row (OpenCV's order).
  std::vector<Eigen::Vector3d> innerCorners() const;
};

// The cameras' shutter: each image gathers the light of exposure_s centred on its capture time (a
// frame's time is its exposure's middle), so what moves (an object, the view while a head turns)
// smears; 0: an instant. The exposure is blur_samples renders at times spread evenly over it,
// averaged.
struct Shutter {
  double exposure_s = 0;
  int blur_samples = 5;
};

struct Scene {
  double backdrop_distance_m = 8.0;  // plane z = d
  double floor_height_m = 1.4;       // plane y = h (y points down)
  double texture_m_per_texel = 0.01;
  unsigned texture_seed = 7;
  std::vector<SceneObject> objects;
  Chessboard chessboard;
  Light light;                  // off unless the scene section has `light`
  std::vector<Poster> posters;  // on the backdrop, the later ones in front
  Shutter camera;               // the `camera` map: an instant unless exposure_s is set

  // Reads the config sections `scene`, `objects` and `chessboard`; errors name file and field.
  // A poster's relative image path is from base_dir (the config file's folder; empty: the
  // current directory).
  static Scene fromConfig(const cv::FileNode& scene, const cv::FileNode& objects,
                          const cv::FileNode& chessboard, const std::string& where,
                          const std::string& base_dir = "");
};

}  // namespace ptz::sim
