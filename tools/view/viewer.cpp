#include "tools/view/viewer.hpp"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>

#include "perception/detect/stereo.hpp"

namespace ptz::tools {
namespace {

std::string format(const char* fmt, double a, double b = 0, double c = 0, double d = 0) {
  char text[160];
  std::snprintf(text, sizeof(text), fmt, a, b, c, d);
  return text;
}

void drawCross(cv::Mat* image) {
  const cv::Point c(image->cols / 2, image->rows / 2);
  cv::line(*image, c - cv::Point(15, 0), c + cv::Point(15, 0), kCentreColour, 1);
  cv::line(*image, c - cv::Point(0, 15), c + cv::Point(0, 15), kCentreColour, 1);
}

void drawDetections(cv::Mat* image, const std::vector<ptzstereo::detection_2d_t>& dets,
                    int target) {
  for (size_t i = 0; i < dets.size(); ++i) {
    const auto& d = dets[i];
    const bool is_target = static_cast<int>(i) == target;
    const cv::Scalar colour = is_target ? kTargetColour : kDetectionColour;
    const cv::Point2d c(d.centroid_x_px, d.centroid_y_px);
    // The outline of a disc of the region's area, its centroid, its box and its class.
    const int radius = static_cast<int>(std::lround(std::sqrt(d.area_px2 / M_PI)));
    cv::circle(*image, c, radius, colour, 2, cv::LINE_AA);
    cv::drawMarker(*image, c, colour, cv::MARKER_CROSS, 8, 1);
    cv::rectangle(*image, cv::Rect(d.bbox_x_px, d.bbox_y_px, d.bbox_width_px, d.bbox_height_px),
                  colour, 1);
    cv::putText(*image, d.class_name, cv::Point(d.bbox_x_px, std::max(12, d.bbox_y_px - 4)),
                cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
  }
}

// The pixels of `from`'s ray through `px` seen by `to`, from 0.3 to 50 m: a polyline, exact
// with distortion (the line bends).
void drawEpipolar(cv::Mat* image, const CameraView& from, const CameraView& to,
                  const Eigen::Vector2d& px) {
  const Eigen::Vector3d ray = perception::pixelRay(from, px);
  std::vector<cv::Point> line;
  for (double r = 0.3; r < 50; r *= 1.05) {
    const Eigen::Vector2d p = to.project(from.position_head_m + r * ray);
    if (p.allFinite() && std::abs(p.x()) < 1e5 && std::abs(p.y()) < 1e5) {
      line.emplace_back(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y())));
    }
  }
  if (line.size() >= 2) cv::polylines(*image, line, false, kEpipolarColour, 1, cv::LINE_AA);
}

}  // namespace

cv::Mat drawView(const StereoRig& rig, const ViewInput& in) {
  const int w = in.left.cols, h = in.left.rows;
  cv::Mat canvas(h + kPanelHeightPx, 2 * w, CV_8UC3, cv::Scalar(32, 32, 32));
  cv::Mat left = canvas(cv::Rect(0, 0, w, h)), right = canvas(cv::Rect(w, 0, w, h));
  in.left.copyTo(left);
  if (in.right.size() == in.left.size()) in.right.copyTo(right);
  drawCross(&left);
  drawCross(&right);
  int target_left = -1, target_right = -1;
  const ptzstereo::object_3d_t* target = nullptr;
  if (in.pose && in.pose->target_index >= 0 &&
      in.pose->target_index < static_cast<int32_t>(in.pose->objects.size())) {
    target = &in.pose->objects[static_cast<size_t>(in.pose->target_index)];
    target_left = target->left_index;
    target_right = target->right_index;
  }
  if (in.detections) {
    drawDetections(&left, in.detections->left, target_left);
    drawDetections(&right, in.detections->right, target_right);
    const CameraView lv = rig.view(Side::kLeft, in.left_ptz),
                     rv = rig.view(Side::kRight, in.right_ptz);
    if (target_left >= 0 && target_left < in.detections->num_left) {
      const auto& d = in.detections->left[static_cast<size_t>(target_left)];
      drawEpipolar(&right, lv, rv, {d.centroid_x_px, d.centroid_y_px});
    }
    if (target_right >= 0 && target_right < in.detections->num_right) {
      const auto& d = in.detections->right[static_cast<size_t>(target_right)];
      drawEpipolar(&left, rv, lv, {d.centroid_x_px, d.centroid_y_px});
    }
  }
  // The text panel: one column per camera, then the target and the loop.
  const cv::Scalar text(230, 230, 230);
  auto put = [&](const std::string& s, int x, int row) {
    cv::putText(canvas, s, cv::Point(x, h + 22 + 24 * row), cv::FONT_HERSHEY_SIMPLEX, 0.5, text, 1,
                cv::LINE_AA);
  };
  const PtzPose* poses[2] = {&in.left_ptz, &in.right_ptz};
  const char* names[2] = {"left", "right"};
  for (int i = 0; i < 2; ++i) {
    const PtzPose& p = *poses[i];
    put(format(i == 0 ? "left   pan %+7.2f deg  tilt %+7.2f deg  zoom %5.2fx"
                      : "right  pan %+7.2f deg  tilt %+7.2f deg  zoom %5.2fx",
               p.pan_rad * 180 / M_PI, p.tilt_rad * 180 / M_PI, p.zoom),
        10 + i * w, 0);
    if (in.setpoint) {
      const auto& s = i == 0 ? in.setpoint->left : in.setpoint->right;
      put(format("setpoint %+7.2f deg       %+7.2f deg       %5.2fx", s.pan_rad * 180 / M_PI,
                 s.tilt_rad * 180 / M_PI, s.zoom),
          10 + i * w, 1);
    } else {
      put(std::string(names[i]) + ": no setpoint yet", 10 + i * w, 1);
    }
  }
  if (target) {
    const double* p = target->position_m;
    put(format("target  x %+6.3f  y %+6.3f  z %6.3f m   range %6.3f m", p[0], p[1], p[2],
               std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2])),
        10, 2);
  } else {
    put("target: not seen in this frame", 10, 2);
  }
  put(format("loop delay p50 %.1f ms  p99 %.1f ms", in.delay_ms_p50, in.delay_ms_p99), 10 + w, 2);
  put(format("frame %.0f   frames %.1f Hz   drawn %.1f Hz   not drawn %.0f",
             static_cast<double>(in.seq), in.frame_rate_hz, in.drawn_rate_hz,
             static_cast<double>(in.frames_dropped)),
      10, 3);
  if (in.paused) put("PAUSED  (p: resume, n: step, s: screenshot, q: quit)", 10 + w, 3);
  return canvas;
}

}  // namespace ptz::tools
