// Ray-casting renderer of the scene through a distorted pinhole camera. Each pixel's ray comes
// from an undistortion map (cached per intrinsics), so lens distortion is exact, not a warp.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "common/rig.hpp"
#include "sim/scene.hpp"

namespace ptz::sim {

class Renderer {
 public:
  explicit Renderer(const Scene& scene);

  // Renders the scene at time t_s into an 8-bit BGR image of the view's size (no noise). With
  // visible_fraction: each scene object's share of its pixels in the image that no nearer
  // object (or the chessboard) hides; 0 where it has none in the image.
  void render(const CameraView& view, double t_s, cv::Mat* bgr,
              std::vector<double>* visible_fraction = nullptr);

  // Per-pixel undistorted normalised coordinates (x/z, y/z) of a view's pixels (CV_32FC2).
  const cv::Mat& rays(const CameraView& view);

 private:
  struct RayCache {
    int width = 0, height = 0;
    Intrinsics intrinsics;
    cv::Mat rays;
  };
  // Returns the pixels where the object's surface is in front of the camera (hidden or not);
  // where it is the nearest, owner_ becomes its index.
  int64_t drawObject(const SceneObject& object, int32_t index, double t_s, const CameraView& view,
                     const cv::Mat& rays, cv::Mat* bgr, cv::Mat* depth);
  void drawChessboard(const CameraView& view, const cv::Mat& rays, cv::Mat* bgr, cv::Mat* depth);

  const Scene& scene_;
  cv::Mat atlas_;                      // backdrop and floor textures, BGR8
  cv::Mat map_xy_, map_frac_, depth_;  // per-frame scratch, kept to avoid reallocation
  cv::Mat owner_;                      // CV_32S: the object each pixel shows (-1: none)
  std::vector<RayCache> caches_;
};

// Adds zero-mean Gaussian pixel noise from a bank drawn once (a random offset per frame), so the
// noise costs a copy and stays deterministic for a given seed and frame index.
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
