// Pictures the simulator paints on planes: a face printed on a box's face (drawn so that OpenCV's
// frontal-face cascades find it) and a walking person's cut-out figure (shaped as the pedestrians
// its HOG people detector was trained on). Both are drawn, not loaded: a scene needs no files.
#pragma once

#include <opencv2/core.hpp>

namespace ptz::sim {

// A frontal face, BGR reflectance (255: white), side_px square; the face fills the square.
cv::Mat facePicture(int side_px);

// A person seen from the front, BGRA (alpha 0 outside the figure), height_px tall and
// height_px / 2 wide; the head's top at row 0 and the feet at the last row. stride: how far the
// feet are apart, as a share of the height (0: standing; 0.15: a long step); the arms swing with
// it. shirt_bgr: the shirt's colour.
cv::Mat personPicture(int height_px, double stride, const cv::Vec3b& shirt_bgr);

}  // namespace ptz::sim
