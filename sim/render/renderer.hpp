// Ray-casting renderer of the scene through a distorted pinhole camera. Each pixel's ray comes
// from an undistortion map (cached per intrinsics), so lens distortion is exact, not a warp.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <tuple>
#include <vector>

#include "common/rig.hpp"
#include "sim/scene/scene.hpp"

namespace ptz::sim {

class Renderer {
 public:
  explicit Renderer(const Scene& scene);

  // Renders the scene at time t_s into an 8-bit BGR image of the view's size (no noise), the
  // objects shaded by the light's direction at t_s and, with the light's shadows, their shadows
  // on the floor. With visible_fraction: each scene object's share of its pixels in the image
  // that no nearer object (or the chessboard) hides; 0 where it has none in the image.
  // On all of OpenCV's threads (cv::setNumThreads), in bands of rows: every pixel is computed
  // alone, so image and fractions are byte-identical for any thread or band count.
  void render(const CameraView& view, double t_s, cv::Mat* bgr,
              std::vector<double>* visible_fraction = nullptr);

  // Per-pixel undistorted normalised coordinates (x/z, y/z) of a view's pixels (CV_32FC2), as
  // the render uses them.
  const cv::Mat& rays(const CameraView& view);

  // Bands of rows the image is cut into (0: about 32 rows each); any count gives the same image.
  void setBands(int bands) { bands_ = bands; }

 private:
  // Undistorted normalised coordinates of every kGridStep-th pixel, per intrinsics: the rays of
  // the pixels between are interpolated where a band needs them.
  struct RayGrid {
    int width = 0, height = 0;
    Intrinsics intrinsics;
    int columns = 0;  // grid points per row
    std::vector<cv::Point2f> points;
  };
  // A band's rays: those of rows [row0, row0 + rays->rows) of the image.
  struct RayRows {
    const cv::Mat* rays = nullptr;
    int row0 = 0;
    const cv::Vec2f* row(int v) const { return rays->ptr<cv::Vec2f>(v - row0); }
  };
  // One thread's memory for its bands' rays, kept from band to band.
  struct RayScratch {
    cv::Mat storage, rays;  // rays: the first rows of storage
    std::vector<cv::Point2f> top, span;
  };
  const RayGrid& rayGrid(const CameraView& view);
  static RayRows interpolateRays(const RayGrid& grid, int row0, int row1, RayScratch* scratch);
  // What the background (floor, backdrop, posters, chessboard) was last drawn for.
  struct BackgroundKey {
    int width = 0, height = 0;
    Intrinsics intrinsics;
    Eigen::Matrix3d rotation_head_camera;
    Eigen::Vector3d position_head_m;
    double backdrop_distance_m = 0, floor_height_m = 0, texture_m_per_texel = 0;
    Chessboard chessboard;
    std::vector<Poster> posters;
  };
  // An object at this frame's time: what every band needs of it.
  struct ObjectFrame {
    cv::Rect rect;         // pixels its image may cover
    cv::Rect shadow_rect;  // pixels its shadow on the floor may cover (none without shadows)
    Eigen::Vector3d centre;
    Eigen::Vector3d oc, oc_box;
    Eigen::Matrix3d box_to_head;
    cv::Mat picture;  // a person's figure at this time: BGRA, colours premultiplied by alpha
    cv::Mat edge;     // CV_8U: its cells within kEdgeCells of the figure's outline
  };
  static constexpr int kEdgeCells = 8;
  // A picture on a plane of an object's frame: its centre, its axes (columns x, y along the
  // picture's columns and rows, z its normal) and its size.
  struct PicturePlane {
    Eigen::Vector3d centre_m;
    Eigen::Matrix3d axes;
    double width_m = 0, height_m = 0;
    int cols = 0, rows = 0;
  };
  static constexpr int kSubRays = 4;  // a pixel's sub-rays through a picture, each way
  // The picture's cells (x col, y row) the pixel (u, v)'s kSubRays^2 sub-rays meet, (-1, -1) off
  // the picture. t: the central ray's length to the plane.
  BackgroundKey backgroundKey(const CameraView& view) const;
  static bool sameBackground(const BackgroundKey& a, const BackgroundKey& b);
  // Rows [row0, row1) of the background into bgr and background_depth_.
  void drawBackground(const CameraView& view, const RayRows& rays, const cv::Rect& board_rect,
                      int row0, int row1, cv::Mat* bgr);
  // Rows [row0, row1) of the object: returns its pixels there where its surface is in front of
  // the camera (hidden or not); where it is the nearest, owner_ becomes its index.
  int64_t drawObject(const SceneObject& object, const ObjectFrame& frame, int32_t index,
                     const CameraView& view, const RayRows& rays, int row0, int row1, cv::Mat* bgr);
  static std::array<cv::Point, kSubRays * kSubRays> subRayCells(const ObjectFrame& frame,
                                                                const Eigen::Matrix3d& R,
                                                                const RayRows& rays,
                                                                const CameraView& view, int u,
                                                                int v, const PicturePlane& plane);
  // The reflectance (1: white) of the prints on the box face the pixel (u, v) hits at p_box (box
  // frame; inward: the face's inward normal; t: the ray's length); 1 where no print is near.
  static cv::Vec3f printReflectance(const SceneObject& object, const ObjectFrame& frame,
                                    const Eigen::Matrix3d& R, const RayRows& rays,
                                    const CameraView& view, int u, int v,
                                    const Eigen::Vector3d& p_box, const Eigen::Vector3d& inward,
                                    double t);
  // Row v of what an object draws: bgr's pixels, depth_ and owner_.
  std::tuple<cv::Vec3b*, float*, int32_t*> objectRow(cv::Mat* bgr, int v) {
    return {bgr->ptr<cv::Vec3b>(v), depth_.ptr<float>(v), owner_.ptr<int32_t>(v)};
  }
  // A person's pixels in rows [row0, row1) (as drawObject).
  int64_t drawPerson(const SceneObject& object, const ObjectFrame& frame, int32_t index,
                     const CameraView& view, const RayRows& rays, int v0, int v1, cv::Mat* bgr);
  void drawChessboard(const CameraView& view, const RayRows& rays, const cv::Rect& rect, int row0,
                      int row1, cv::Mat* bgr);
  // The posters over rows [row0, row1) of the backdrop just drawn (not over the floor).
  void drawPosters(const CameraView& view, const RayRows& rays, int row0, int row1, cv::Mat* bgr);
  // The objects' shadows over rows [row0, row1) of the floor in bgr (the background copied, the
  // objects not drawn yet): within the objects' shadow_rect only.
  void drawShadows(const CameraView& view, const RayRows& rays, int row0, int row1, cv::Mat* bgr);
  // Whether the object blocks the way from the floor point p toward the light.
  bool blocksLight(const SceneObject& object, const ObjectFrame& frame,
                   const Eigen::Vector3d& p) const;

  const Scene& scene_;
  cv::Mat atlas_;                      // backdrop and floor textures, BGR8
  cv::Mat map_xy_, map_frac_, depth_;  // per-frame scratch, kept to avoid reallocation
  cv::Mat owner_;                      // CV_32S: the object each pixel shows (-1: none)
  cv::Mat background_depth_;           // CV_32F, m along the ray: the last background's
  cv::Mat background_;                 // BGR8: the last background's image while kept
  bool background_drawn_ = false, background_kept_ = false;
  BackgroundKey background_key_;
  std::vector<ObjectFrame> objects_;  // this frame's
  Eigen::Vector3d to_light_;          // this frame's direction toward the light
  std::vector<int64_t> band_counts_;  // per band, per object: footprint and shown pixels
  std::vector<RayGrid> grids_;        // the last few intrinsics', newest last
  cv::Mat rays_;                      // rays()'s
  int bands_ = 0;
};

// Adds zero-mean Gaussian pixel noise from a bank drawn once (a random offset per frame), so the
// noise costs a copy (in bands of rows on all threads) and stays deterministic for a given seed
// and frame index.
class NoiseBank {
 public:
  NoiseBank(int width, int height, double sigma, unsigned seed);
  void apply(uint64_t frame_index, int camera, cv::Mat* bgr) const;
  double sigma() const { return sigma_; }

 private:
  double sigma_;
  unsigned seed_;
  cv::Mat positive_, negative_;  // CV_8UC3 parts of one noise field, larger than an image
};

}  // namespace ptz::sim
