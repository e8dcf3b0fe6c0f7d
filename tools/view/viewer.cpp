#include "tools/view/viewer.hpp"

#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "perception/detection/stereo.hpp"

namespace ptz::tools {
namespace {

std::string format(const char* fmt, double a, double b = 0, double c = 0, double d = 0) {
  char text[160];
  std::snprintf(text, sizeof(text), fmt, a, b, c, d);
  return text;
}

// s cut to fit max_width_px ("..." marks the cut) and made printable: the strings come from
// outside and may be of any length.
std::string fitText(const std::string& s, int max_width_px, double scale) {
  std::string t = s.substr(0, 240);
  for (char& ch : t) {
    if (ch < 32 || ch > 126) ch = '?';
  }
  int baseline = 0;
  auto width = [&](const std::string& x) {
    return cv::getTextSize(x, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline).width;
  };
  if (width(t) <= max_width_px) return t;
  while (!t.empty() && width(t + "...") > max_width_px) t.pop_back();
  return t + "...";
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

void drawDashedCircle(cv::Mat* image, cv::Point c, int r, const cv::Scalar& colour) {
  for (int a = 0; a < 360; a += 30) {
    cv::ellipse(*image, c, cv::Size(r, r), 0, a, a + 15, colour, 1, cv::LINE_AA);
  }
}

const char* trackStateName(int8_t state) {
  switch (state) {
    case ptzstereo::object_track_t::STATE_TENTATIVE:
      return " tentative";
    case ptzstereo::object_track_t::STATE_CONFIRMED:
      return "";
    case ptzstereo::object_track_t::STATE_COASTING:
      return " coasting";
    default:
      return " state?";
  }
}

// An object's axes (x red, y green, z blue, as RViz and Foxglove draw them), length_m long from
// its centre p: its orientation seen. Nothing for a quaternion that is not a finite unit one.
void drawAxes(cv::Mat* image, const CameraView& view, const Eigen::Vector3d& p, const double* wxyz,
              double length_m) {
  const Eigen::Quaterniond q(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  if (!q.coeffs().allFinite() || std::abs(q.norm() - 1) > 1e-3) return;
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  const Eigen::Vector2d o = view.project(p);
  const cv::Scalar colours[3] = {cv::Scalar(0, 0, 255), cv::Scalar(0, 255, 0),
                                 cv::Scalar(255, 0, 0)};
  auto inside = [](const Eigen::Vector2d& x) {
    return x.allFinite() && std::abs(x.x()) < 1e5 && std::abs(x.y()) < 1e5;
  };
  if (!inside(o)) return;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector2d e = view.project(p + length_m * R.col(k));
    if (!inside(e)) continue;
    cv::arrowedLine(*image, cv::Point2d(o.x(), o.y()), cv::Point2d(e.x(), e.y()), colours[k], 2,
                    cv::LINE_AA, 0, 0.15);
  }
}

// One track through one camera: a circle of its apparent radius (fx r / range, as ptz-detect
// measures it), an x at its centre, its axes when it has an orientation, "#id class" below. Not
// drawn where the camera cannot see it.
void drawTrack(cv::Mat* image, const CameraView& view, const ptzstereo::object_track_t& t,
               bool is_target) {
  const Eigen::Vector3d p(t.position_m[0], t.position_m[1], t.position_m[2]);
  if (!p.allFinite()) return;
  const Eigen::Vector2d px = view.project(p);
  if (!px.allFinite() || std::abs(px.x()) > 1e5 || std::abs(px.y()) > 1e5) return;
  const double range_m = (p - view.position_head_m).norm();
  double radius_px = 0;
  if (std::isfinite(t.radius_m) && t.radius_m > 0 && range_m > 0) {
    radius_px =
        std::min(view.intrinsics.fx * t.radius_m / range_m, 2.0 * (image->cols + image->rows));
  }
  const bool tentative = t.state == ptzstereo::object_track_t::STATE_TENTATIVE;
  const bool coasting = t.state == ptzstereo::object_track_t::STATE_COASTING;
  const cv::Scalar colour = is_target ? kTargetColour : coasting ? kCoastingColour : kTrackColour;
  const cv::Point c(static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y())));
  const int r = static_cast<int>(std::lround(radius_px));
  if (r > 0) {
    if (tentative && !is_target) {
      drawDashedCircle(image, c, r, colour);
    } else {
      cv::circle(*image, c, r, colour, is_target ? 3 : 2, cv::LINE_AA);
    }
  }
  if (t.has_orientation) drawAxes(image, view, p, t.orientation_wxyz, std::max(t.radius_m, 0.05));
  // Not anti-aliased: the centre pixel is exactly the colour.
  cv::drawMarker(*image, c, colour, cv::MARKER_TILTED_CROSS, 10, 1, cv::LINE_8);
  if (c.x < 0 || c.y < 0 || c.x >= image->cols || c.y >= image->rows) return;
  const std::string label = fitText("#" + std::to_string(t.id) + " " + t.class_name.substr(0, 40) +
                                        (is_target ? " TARGET" : "") + trackStateName(t.state),
                                    image->cols - 4, 0.45);
  int baseline = 0;
  const int text_w = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.45, 1, &baseline).width;
  const cv::Point at(std::clamp(c.x - r, 2, std::max(2, image->cols - text_w - 2)),
                     std::clamp(c.y + r + 16, 14, image->rows - 4));
  // A dark rim keeps the label readable on any image.
  cv::putText(*image, label, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 3,
              cv::LINE_AA);
  cv::putText(*image, label, at, cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
}

// The frame's tracks (the first kMaxTracksDrawn), the target last so it is on top.
void drawTracks(cv::Mat* image, const CameraView& view, const ptzstereo::object_tracks_t& m) {
  const size_t n = std::min(m.tracks.size(), static_cast<size_t>(kMaxTracksDrawn));
  const ptzstereo::object_track_t* target = nullptr;
  for (size_t i = 0; i < n; ++i) {
    const auto& t = m.tracks[i];
    if (t.id == m.target_id && m.target_id >= 0) {
      target = &t;
    } else {
      drawTrack(image, view, t, false);
    }
  }
  if (target) drawTrack(image, view, *target, true);
}

std::string controlLine(const ViewInput& in) {
  if (!in.control) return "control: no state yet";
  const auto& s = *in.control;
  // Without a target the reason says so ("no target: searching ...").
  const std::string line = "control " + controlStateText(s) + "   ";
  if (s.target_id < 0) return line + (s.reason.empty() ? "no target" : s.reason);
  return line + "target #" + std::to_string(s.target_id) + ": " + s.reason;
}

std::string tracksLine(const ViewInput& in) {
  if (!in.tracks) return "tracks: none for this frame";
  const auto& m = *in.tracks;
  std::string line =
      "detect " + std::to_string(m.tracks.size()) + (m.tracks.size() == 1 ? " track" : " tracks");
  if (m.tracks.size() > static_cast<size_t>(kMaxTracksDrawn)) {
    line += " (" + std::to_string(kMaxTracksDrawn) + " drawn)";
  }
  if (m.target_id < 0)
    return line + "   " + (m.target_reason.empty() ? "no target" : m.target_reason);
  return line + "   target #" + std::to_string(m.target_id) + ": " + m.target_reason;
}

}  // namespace

std::string controlStateText(const ptzstereo::control_state_t& s) {
  char text[96];
  switch (s.state) {
    case ptzstereo::control_state_t::STATE_TRACKING:
      return "TRACKING";
    case ptzstereo::control_state_t::STATE_COASTING:
      std::snprintf(text, sizeof(text), "COASTING %.1f s", s.since_target_s);
      return text;
    case ptzstereo::control_state_t::STATE_SEARCHING:
      std::snprintf(text, sizeof(text), "SEARCHING %d/%d", s.search_waypoint + 1,
                    s.search_waypoints);
      return text;
    case ptzstereo::control_state_t::STATE_HOLDING:
      std::snprintf(text, sizeof(text), "HOLDING %.1f s", s.since_target_s);
      return text;
    case ptzstereo::control_state_t::STATE_HOMING:
      return "HOMING";
    default:
      return "STATE " + std::to_string(s.state) + "?";
  }
}

std::optional<ptzstereo::target_select_t> clickToSelect(int x, int y, int image_width,
                                                        int image_height, int64_t frame_seq,
                                                        int64_t now_utime) {
  if (image_width <= 0 || x < 0 || y < 0 || y >= image_height || x >= 2 * image_width) {
    return std::nullopt;
  }
  const bool right = x >= image_width;
  ptzstereo::target_select_t m{};
  m.utime = now_utime;
  m.publish_utime = now_utime;
  m.mode = ptzstereo::target_select_t::MODE_IMAGE_POINT;
  m.track_id = -1;
  m.camera =
      right ? ptzstereo::target_select_t::CAMERA_RIGHT : ptzstereo::target_select_t::CAMERA_LEFT;
  m.x_px = right ? x - image_width : x;
  m.y_px = y;
  m.frame_seq = frame_seq;
  return m;
}

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
  const CameraView lv = rig.view(Side::kLeft, in.left_ptz),
                   rv = rig.view(Side::kRight, in.right_ptz);
  if (in.detections) {
    drawDetections(&left, in.detections->left, target_left);
    drawDetections(&right, in.detections->right, target_right);
    if (target_left >= 0 && target_left < in.detections->num_left) {
      const auto& d = in.detections->left[static_cast<size_t>(target_left)];
      drawEpipolar(&right, lv, rv, {d.centroid_x_px, d.centroid_y_px});
    }
    if (target_right >= 0 && target_right < in.detections->num_right) {
      const auto& d = in.detections->right[static_cast<size_t>(target_right)];
      drawEpipolar(&left, rv, lv, {d.centroid_x_px, d.centroid_y_px});
    }
  }
  if (in.tracks) {
    drawTracks(&left, lv, *in.tracks);
    drawTracks(&right, rv, *in.tracks);
  }
  // The text panel: one column per camera, then the target and the loop, then the states.
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
  // The states across the whole width: their reasons are sentences.
  put(fitText(controlLine(in), 2 * w - 20, 0.5), 10, 4);
  put(fitText(tracksLine(in), 2 * w - 20, 0.5), 10, 5);
  return canvas;
}

}  // namespace ptz::tools
