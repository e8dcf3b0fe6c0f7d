#include "ptz_driver/head_calibrate/head_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

namespace ptz::driver {
namespace {

constexpr double kMoves[] = {1, -1, 2, -2};  // in steps of move_rad, about home
constexpr double kPi = 3.14159265358979323846;

std::string format(const char* pattern, double a, double b = 0, double c = 0, double d = 0) {
  char text[160];
  std::snprintf(text, sizeof text, pattern, a, b, c, d);
  return text;
}

Side sideOf(size_t s) {
  return s == 0 ? Side::kLeft : Side::kRight;
}

// The widest zoom: where pan and tilt are measured and the zoom chain starts.
double minZoom(const StereoRig& rig, size_t side) {
  return rig.camera(sideOf(side)).minZoom();
}

}  // namespace

HeadCalibration::HeadCalibration(StereoRig rig, UnitMapGuess guess,
                                 HeadCalibrationSettings settings)
    : rig_(std::move(rig)), guess_(std::move(guess)), settings_(settings) {
  target_ = previous_target_ = guess_.home;
}

std::vector<std::string> HeadCalibration::takeLog() {
  return std::exchange(log_, {});
}

void HeadCalibration::fail(const std::string& why) {
  state_ = State::kFailed;
  error_ = why;
}

void HeadCalibration::moveTo(const UnitPose& target, double now_s) {
  previous_target_ = target_;
  target_ = target;
  if (guess_.unit_step > 0) {  // where the head can go, so that what is measured is where it went
    for (double* u : {&target_.pan, &target_.tilt, &target_.zoom}) {
      *u = std::round(*u / guess_.unit_step) * guess_.unit_step;
    }
  }
  moved_at_s_ = now_s;
  window_start_s_ = -1;
}

bool HeadCalibration::arrived(const std::array<std::optional<UnitPose>, 2>& measured) const {
  // Within a part of the move, or of a usual move for an axis that moved little or not at all.
  const auto near = [&](double at, double to, double from, double usual) {
    return std::abs(at - to) <= settings_.arrive_fraction * std::max(std::abs(to - from), usual);
  };
  const double zoom_usual =
      (guess_.zoom_max_units - guess_.home.zoom) / settings_.zoom_positions_min;
  for (const auto& m : measured) {
    if (!m) return false;
    if (!near(m->pan, target_.pan, previous_target_.pan,
              settings_.move_rad * std::abs(guess_.pan_units_per_rad)) ||
        !near(m->tilt, target_.tilt, previous_target_.tilt,
              settings_.move_rad * std::abs(guess_.tilt_units_per_rad)) ||
        !near(m->zoom, target_.zoom, previous_target_.zoom, zoom_usual)) {
      return false;
    }
  }
  return true;
}

bool HeadCalibration::settled(const cv::Mat& left, const cv::Mat& right, double now_s) {
  const cv::Mat* images[2] = {&left, &right};
  if (window_start_s_ < 0) {
    for (size_t s = 0; s < 2; ++s) {
      window_[s] = images[s]->clone();
      window_corners_[s] = findCorners(window_[s], 200);
    }
    window_start_s_ = now_s;
    return false;
  }
  if (now_s - window_start_s_ < settings_.settle_s) return false;
  double shift_px = 0;
  for (size_t s = 0; s < 2; ++s) {
    shift_px = std::max(shift_px, imageMotionPx(track(window_[s], *images[s], window_corners_[s])));
  }
  if (shift_px <= settings_.settle_px) return true;
  window_start_s_ = -1;  // still moving: a new window from the next frame
  return false;
}

HeadCalibration::State HeadCalibration::onFrame(
    const cv::Mat& left, const cv::Mat& right, double now_s,
    const std::array<std::optional<UnitPose>, 2>& measured) {
  if (state_ != State::kRunning) return state_;
  if (moved_at_s_ == 0) {  // the first frame: the clock starts, from where the heads are
    moved_at_s_ = now_s;
    if (measured[0]) previous_target_ = *measured[0];
  }
  if (now_s - moved_at_s_ > settings_.move_timeout_s) {
    std::string where = "unknown";
    for (size_t s = 0; s < 2; ++s) {
      if (measured[s]) {
        where = format("pan %.6g tilt %.6g zoom %.6g", measured[s]->pan, measured[s]->tilt,
                       measured[s]->zoom);
      }
    }
    fail(format("the heads did not reach pan %.6g tilt %.6g zoom %.6g and hold still within "
                "%.3g s",
                target_.pan, target_.tilt, target_.zoom, settings_.move_timeout_s) +
         " (last measured: " + where +
         "; a moving scene, or a head that stops short: raise arrive_fraction)");
    return state_;
  }
  if (!arrived(measured)) {
    window_start_s_ = -1;
    return state_;
  }
  if (!settled(left, right, now_s)) return state_;
  measure(left, right, now_s);
  return state_;
}

void HeadCalibration::measure(const cv::Mat& left, const cv::Mat& right, double now_s) {
  switch (phase_) {
    case Phase::kHome: {
      const cv::Mat* images[2] = {&left, &right};
      for (size_t s = 0; s < 2; ++s) {
        home_[s] = images[s]->clone();
        scene_[s] = triangulateAtHome(rig_, sideOf(s), minZoom(rig_, s), left, right,
                                      settings_.max_corners);
        if (scene_[s].pixels.size() < 2 * kMinFitPoints) {
          fail(std::string(s == 0 ? "left" : "right") + " camera: only " +
               std::to_string(scene_[s].pixels.size()) +
               " corners at home were seen by both cameras (at least " +
               std::to_string(2 * kMinFitPoints) +
               "): point the rig at a static, textured scene, and check the rig file");
          return;
        }
      }
      log(format("home: %.0f (left) and %.0f (right) corners seen by both cameras",
                 scene_[0].pixels.size(), scene_[1].pixels.size()));
      phase_ = Phase::kPan;
      move_ = 0;
      step_units_ = settings_.move_rad * guess_.pan_units_per_rad;
      UnitPose next = guess_.home;
      next.pan += kMoves[0] * step_units_;
      moveTo(next, now_s);
      return;
    }
    case Phase::kPan:
    case Phase::kTilt:
      measureTurn(left, right, now_s);
      return;
    case Phase::kZoom:
      measureZoom(left, right, now_s);
      return;
  }
}

void HeadCalibration::measureTurn(const cv::Mat& left, const cv::Mat& right, double now_s) {
  const bool pan = phase_ == Phase::kPan;
  const double units = pan ? target_.pan - guess_.home.pan : target_.tilt - guess_.home.tilt;
  double& units_per_rad = pan ? guess_.pan_units_per_rad : guess_.tilt_units_per_rad;
  const cv::Mat* images[2] = {&left, &right};
  std::string line = format(pan ? "pan %+.6g units:" : "tilt %+.6g units:", units);
  double rad_sum = 0;
  for (size_t s = 0; s < 2; ++s) {
    const Side side = sideOf(s);
    const double zoom = minZoom(rig_, s);
    const double pan_guess = pan ? units / units_per_rad : 0;
    const double tilt_guess = pan ? 0 : units / units_per_rad;
    const CameraView expected = rig_.view(side, PtzPose{pan_guess, tilt_guess, zoom});
    std::vector<cv::Point2f> predicted;
    for (const auto& p : scene_[s].points_head_m) {
      const Eigen::Vector2d px = expected.project(p);
      predicted.emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()));
    }
    const Tracks t = track(home_[s], *images[s], scene_[s].pixels, predicted);
    std::vector<Eigen::Vector3d> points;
    for (int i : t.index) points.push_back(scene_[s].points_head_m[i]);
    const Fit fit = fitPanTilt(rig_, side, zoom, points, t.to, pan_guess, tilt_guess);
    if (!fit.ok) {
      fail(std::string(s == 0 ? "left" : "right") + " camera, " + line + " " + fit.why);
      return;
    }
    const double rad = fit.value[pan ? 0 : 1];
    moves_[s].emplace_back(units, rad);
    rad_sum += rad;
    line += std::string(s == 0 ? " left " : ", right ") +
            format("%.5f deg (%.0f corners, %.3f px)", rad * 180 / kPi, fit.inliers, fit.rms_px);
  }
  log(line);
  // The first move tells the scale well enough to size the rest (the model file may be far off).
  if (move_ == 0 && std::abs(rad_sum) > 1e-6) units_per_rad = 2 * units / rad_sum;
  if (move_ == 0) step_units_ = settings_.move_rad * units_per_rad;
  ++move_;
  UnitPose next = guess_.home;
  if (move_ < std::size(kMoves)) {
    (pan ? next.pan : next.tilt) += kMoves[move_] * step_units_;
    moveTo(next, now_s);
    return;
  }
  for (size_t s = 0; s < 2; ++s) {
    double uu = 0, ur = 0;
    for (const auto& [u, r] : moves_[s]) uu += u * u, ur += u * r;
    const double rad_per_unit = ur / uu;
    double sq = 0;
    for (const auto& [u, r] : moves_[s]) sq += (r - rad_per_unit * u) * (r - rad_per_unit * u);
    (pan ? map_.pan_units_per_rad : map_.tilt_units_per_rad)[s] = 1 / rad_per_unit;
    (pan ? map_.pan_rms_rad : map_.tilt_rms_rad)[s] = std::sqrt(sq / moves_[s].size());
    moves_[s].clear();
  }
  move_ = 0;
  if (pan) {
    phase_ = Phase::kTilt;
    step_units_ = settings_.move_rad * guess_.tilt_units_per_rad;
    next.tilt += kMoves[0] * step_units_;
  } else {
    phase_ = Phase::kZoom;
  }
  moveTo(next, now_s);
}

void HeadCalibration::measureZoom(const cv::Mat& left, const cv::Mat& right, double now_s) {
  const cv::Mat* images[2] = {&left, &right};
  if (zoom_images_.empty()) {  // at home: the widest zoom is the rig's smallest
    map_.zoom_units.push_back(target_.zoom);
    for (size_t s = 0; s < 2; ++s) map_.zoom_ratios[s].push_back(minZoom(rig_, s));
    zoom_images_.push_back(std::array<cv::Mat, 2>{left.clone(), right.clone()});
    nextZoom(now_s);
    return;
  }
  const size_t from = zoom_from_;
  const double du = target_.zoom - map_.zoom_units[from];
  std::array<Fit, 2> fits;
  for (size_t s = 0; s < 2; ++s) {
    const Side side = sideOf(s);
    const double ratio_from = map_.zoom_ratios[s][from];
    const cv::Mat& image_from = zoom_images_[from][s];
    const std::vector<cv::Point2f> corners = findCorners(image_from, settings_.max_corners);
    const Tracks t = track(image_from, *images[s], corners,
                           zoomedPixels(rig_, side, ratio_from, zoom_guess_[s], corners));
    fits[s] = fitZoom(rig_, side, ratio_from, t.from, t.to, zoom_guess_[s]);
    if (fits[s].ok && !(fits[s].value[0] > ratio_from)) {
      fits[s].ok = false;
      fits[s].why =
          format("the zoom ratio did not grow (%.4f after %.4f)", fits[s].value[0], ratio_from);
    }
    if (fits[s].ok) continue;
    if (!refining_ && du > 1e-3 * guess_.zoom_max_units) {  // too far to track: half the step
      log("zoom " + format("%.6g", target_.zoom) + " units: " + fits[s].why +
          "; trying half the step");
      UnitPose next = target_;
      next.zoom = map_.zoom_units[from] + du / 2;
      for (size_t k = 0; k < 2; ++k) {
        zoom_guess_[k] = (map_.zoom_ratios[k][from] + zoom_guess_[k]) / 2;
      }
      moveTo(next, now_s);
      return;
    }
    fail(std::string(s == 0 ? "left" : "right") + " camera, zoom " +
         format("%.6g units: ", target_.zoom) + fits[s].why);
    return;
  }
  const auto at = static_cast<std::ptrdiff_t>(from + 1);
  map_.zoom_units.insert(map_.zoom_units.begin() + at, target_.zoom);
  for (size_t s = 0; s < 2; ++s) {
    map_.zoom_ratios[s].insert(map_.zoom_ratios[s].begin() + at, fits[s].value[0]);
  }
  zoom_images_.insert(zoom_images_.begin() + at,
                      std::array<cv::Mat, 2>{left.clone(), right.clone()});
  log(format("zoom %.6g units: left %.4fx (%.0f corners, %.3f px)", target_.zoom, fits[0].value[0],
             fits[0].inliers, fits[0].rms_px) +
      format(", right %.4fx (%.0f corners, %.3f px)", fits[1].value[0], fits[1].inliers,
             fits[1].rms_px));
  if (!refining_ && target_.zoom < guess_.zoom_max_units) {
    zoom_slope_ = (fits[0].value[0] - map_.zoom_ratios[0][from] + fits[1].value[0] -
                   map_.zoom_ratios[1][from]) /
                  (2 * du);
    nextZoom(now_s);
    return;
  }
  refining_ = true;
  refineZoom(now_s);
}

void HeadCalibration::nextZoom(double now_s) {
  zoom_from_ = map_.zoom_units.size() - 1;
  const double u = map_.zoom_units.back();
  const double span = guess_.zoom_max_units - guess_.home.zoom;
  std::array<double, 2> ratio = {map_.zoom_ratios[0].back(), map_.zoom_ratios[1].back()};
  double slope = zoom_slope_;
  if (map_.zoom_units.size() < 2) {  // no step measured yet: the model file's slope, scaled
    const double h = span / 100;
    slope = (guess_.zoom_ratio(u + h) - guess_.zoom_ratio(u)) / h * ratio[0] /
            std::max(1e-9, guess_.zoom_ratio(u));
  }
  double du = span / settings_.zoom_positions_min;
  if (slope > 0) {
    du = std::min(du, std::min(ratio[0], ratio[1]) * (settings_.zoom_step_ratio - 1) / slope);
  }
  du = std::max(du, span / (8.0 * settings_.zoom_positions_min));
  UnitPose next = target_;
  next.zoom = std::min(u + du, guess_.zoom_max_units);
  for (size_t s = 0; s < 2; ++s) {
    const double top = rig_.camera(sideOf(s)).maxZoom();
    zoom_guess_[s] = std::clamp(ratio[s] + std::max(slope, 0.0) * (next.zoom - u), ratio[s], top);
  }
  moveTo(next, now_s);
}

double HeadCalibration::interpolationError(size_t i) const {
  const auto& u = map_.zoom_units;
  const auto ratio = [&](size_t k) {
    return (map_.zoom_ratios[0][k] + map_.zoom_ratios[1][k]) / 2;
  };
  const auto slope = [&](size_t k) { return (ratio(k + 1) - ratio(k)) / (u[k + 1] - u[k]); };
  // Were the lens bent like a neighbouring step, the line through this step's ends would miss it
  // by up to a quarter of the slopes' difference times the step's length.
  double bend = 0;
  if (i > 0) bend = std::max(bend, std::abs(slope(i - 1) - slope(i)));
  if (i + 2 < u.size()) bend = std::max(bend, std::abs(slope(i + 1) - slope(i)));
  return bend * (u[i + 1] - u[i]) / 4 / ratio(i);
}

void HeadCalibration::refineZoom(double now_s) {
  const auto& u = map_.zoom_units;
  const double shortest = (guess_.zoom_max_units - guess_.home.zoom) / 1000;
  for (size_t i = 0; i + 1 < u.size(); ++i) {
    UnitPose next = target_;
    next.zoom = (u[i] + u[i + 1]) / 2;
    if (guess_.unit_step > 0)
      next.zoom = std::round(next.zoom / guess_.unit_step) * guess_.unit_step;
    if (u[i + 1] - u[i] < 2 * shortest || next.zoom <= u[i] || next.zoom >= u[i + 1]) continue;
    if (interpolationError(i) <= settings_.zoom_table_tolerance) continue;
    zoom_from_ = i;
    for (size_t s = 0; s < 2; ++s) {
      const auto& r = map_.zoom_ratios[s];
      zoom_guess_[s] = r[i] + (r[i + 1] - r[i]) * (next.zoom - u[i]) / (u[i + 1] - u[i]);
    }
    moveTo(next, now_s);
    return;
  }
  state_ = State::kDone;
}

}  // namespace ptz::driver
