// Chessboard views rendered by the simulator for calibration tests: random rigs, board poses that
// both cameras see, and the corners found in the rendered images.
#pragma once

#include <opencv2/imgproc.hpp>

#include <random>
#include <vector>

#include "common/rig.hpp"
#include "perception/calibrate/calibration.hpp"
#include "sim/render/renderer.hpp"

namespace ptz::test {

inline double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

// A rig drawn at random around a plausible VGA PTZ pair (one zoom entry at 1).
inline StereoRig randomRig(std::mt19937& rng) {
  StereoRig rig = StereoRig::makeDefault();
  for (CameraSpec* cam : {&rig.left, &rig.right}) {
    Intrinsics k;
    k.fx = uniform(rng, 450, 750);
    k.fy = k.fx * uniform(rng, 0.99, 1.01);
    k.cx = 319.5 + uniform(rng, -12, 12);
    k.cy = 239.5 + uniform(rng, -12, 12);
    k.distortion = {uniform(rng, -0.25, 0.05), uniform(rng, -0.05, 0.1), uniform(rng, -1e-3, 1e-3),
                    uniform(rng, -1e-3, 1e-3), 0.0};
    cam->zoom_table = {{1.0, k}};
  }
  const Eigen::Vector3d axis(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
  rig.home.R = Eigen::AngleAxisd(uniform(rng, 0.005, 0.03), axis.normalized()).toRotationMatrix();
  rig.home.T = rig.home.R * Eigen::Vector3d(-uniform(rng, 0.2, 0.4), uniform(rng, -0.01, 0.01),
                                            uniform(rng, -0.01, 0.01));
  return rig;
}

// True when every inner corner (and a margin of one square) projects inside the view.
inline bool boardInside(const sim::Chessboard& board, const CameraView& view, double margin_px) {
  for (const Eigen::Vector3d& p : board.innerCorners()) {
    const Eigen::Vector2d px = view.project(p);
    if (!(px.x() > margin_px && px.y() > margin_px && px.x() < view.width - margin_px &&
          px.y() < view.height - margin_px)) {
      return false;
    }
  }
  return true;
}

// A random board pose in front of the views: centre around `centre`, tilted up to max_tilt_rad
// about an axis in the board plane, visible in every view.
inline bool placeBoard(std::mt19937& rng, const std::vector<CameraView>& views,
                       const Eigen::Vector3d& centre, const Eigen::Vector3d& spread,
                       double max_tilt_rad, sim::Chessboard* board) {
  for (int attempt = 0; attempt < 200; ++attempt) {
    board->centre_head_m =
        centre + Eigen::Vector3d(uniform(rng, -1, 1) * spread.x(), uniform(rng, -1, 1) * spread.y(),
                                 uniform(rng, -1, 1) * spread.z());
    const double a = uniform(rng, 0, 2 * M_PI);
    board->rotation_head_board =
        Eigen::AngleAxisd(uniform(rng, 0.3, 1) * max_tilt_rad,
                          Eigen::Vector3d(std::cos(a), std::sin(a), 0))
            .toRotationMatrix() *
        Eigen::AngleAxisd(uniform(rng, -0.3, 0.3), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    bool inside = true;
    for (const auto& v : views) inside = inside && boardInside(*board, v, 25);
    if (inside) return true;
  }
  return false;
}

// A scene with only the calibration board (9x6 inner corners, 5 cm squares) and its renderer.
struct BoardScene {
  sim::Scene scene;
  sim::Renderer renderer{scene};
  perception::BoardSpec board{9, 6, 0.05};
  BoardScene() {
    scene.chessboard.present = true;
    scene.chessboard.square_m = board.square_m;
  }
  sim::Chessboard& chessboard() { return scene.chessboard; }
  cv::Mat render(const CameraView& view) {
    cv::Mat bgr;
    renderer.render(view, 0.0, &bgr);
    return bgr;
  }
  // Renders the board in the view and finds its corners.
  bool corners(const CameraView& view, std::vector<cv::Point2f>* corners_px) {
    return perception::findCorners(render(view), board, corners_px);
  }
};

// `count` stereo views of the board at random poses seen by both cameras at home.
inline std::vector<perception::ViewPair> stereoViews(const StereoRig& rig, BoardScene* sim,
                                                     std::mt19937& rng, size_t count) {
  const std::vector<CameraView> views = {rig.view(Side::kLeft, {}), rig.view(Side::kRight, {})};
  std::vector<perception::ViewPair> pairs;
  for (size_t i = 0; pairs.size() < count && i < 3 * count; ++i) {
    if (!placeBoard(rng, views, {0, 0, 1.3}, {0.35, 0.25, 0.3}, 0.7, &sim->chessboard())) break;
    perception::ViewPair v{
        "view" + std::to_string(i) + "_left", "view" + std::to_string(i) + "_right", {}, {}};
    if (sim->corners(views[0], &v.left_px) && sim->corners(views[1], &v.right_px)) {
      perception::alignCornerOrder(v.left_px, &v.right_px);
      pairs.push_back(v);
    }
  }
  return pairs;
}

}  // namespace ptz::test
