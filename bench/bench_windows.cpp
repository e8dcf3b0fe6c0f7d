// Windows for speed (perception/detect/windows.hpp): ptz-detect's detection per stereo frame
// (JPEG decoding of what is scanned, detection, association, tracking) with windows around the
// tracked ball and without, on rendered JPEG frames of the default scenario at VGA and 1080p,
// the cameras following the ball. One core; median and p99, the windowed frames' and full scans'
// own medians, and the share of frames scanned whole.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include "bench_util.hpp"
#include "perception/detect/detector.hpp"
#include "perception/detect/jpeg_window.hpp"
#include "perception/detect/stereo.hpp"
#include "perception/detect/tracker.hpp"
#include "perception/detect/windows.hpp"
#include "sim/simulator.hpp"

using ptz::bench::Clock;
using ptz::bench::ms;
using ptz::bench::report;
namespace perception = ptz::perception;

namespace {

// The default rig at another image size: the same horizontal field of view.
ptz::StereoRig rigAt(int width, int height) {
  ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  const double s = width / 640.0;
  for (ptz::CameraSpec* c : {&rig.left, &rig.right}) {
    for (auto& z : c->zoom_table) {
      z.intrinsics.fx *= s;
      z.intrinsics.fy *= s;
      z.intrinsics.cx = (z.intrinsics.cx + 0.5) * s - 0.5;
      z.intrinsics.cy = (z.intrinsics.cy + 0.5) * s - 0.5 + (height - 480 * s) / 2;
    }
    c->width = width;
    c->height = height;
  }
  return rig;
}

struct Frame {
  std::vector<uint8_t> left, right;
  ptz::PtzPose left_pose, right_pose;
  double t_s = 0;
};

// 300 frames (10 s) of the default scenario, both cameras turned to the red ball each frame.
std::vector<Frame> render(const ptz::StereoRig& rig, const ptz::sim::Scene& scene) {
  auto plant = ptz::defaultPlantParams();
  for (auto& a : plant.axis) {
    a.time_constant_s = 1e-4;
    a.max_rate_per_s = 1e6;
  }
  ptz::sim::Simulator sim(rig, scene, plant, 2.0, 1);
  const ptz::sim::SceneObject* ball = nullptr;
  for (const auto& o : scene.objects) {
    if (o.class_name == "red_ball") ball = &o;
  }
  std::vector<Frame> frames;
  for (int i = 0; i < 300; ++i) {
    const double t = i / 30.0;
    const Eigen::Vector3d p = ball->trajectory.position(t + 0.01);
    const double pan = std::atan2(p.x(), p.z()),
                 tilt = std::atan2(-p.y(), std::hypot(p.x(), p.z()));
    int clamped = 0, rejected = 0;
    sim.command(t, {pan, tilt, 1}, {pan - 0.05, tilt, 1}, &clamped, &rejected);
    sim.advanceTo(t + 0.01);
    const ptz::sim::SimFrame f = sim.capture();
    Frame fr;
    cv::imencode(".jpg", f.left, fr.left, {cv::IMWRITE_JPEG_QUALITY, 90});
    cv::imencode(".jpg", f.right, fr.right, {cv::IMWRITE_JPEG_QUALITY, 90});
    fr.left_pose = f.left_pose;
    fr.right_pose = f.right_pose;
    fr.t_s = f.t_s;
    frames.push_back(std::move(fr));
  }
  return frames;
}

perception::DecodeParts decoder(const std::vector<uint8_t>& jpeg, cv::Size size) {
  return [&jpeg, size](const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* parts,
                       std::string* why) {
    if (rects.size() == 1 && rects[0] == cv::Rect({0, 0}, size)) {
      parts->assign(1, cv::imdecode(jpeg, cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION));
      return !(*parts)[0].empty();
    }
    return perception::decodeJpegWindows(jpeg.data(), jpeg.size(), size.width, size.height, rects,
                                         parts, why);
  };
}

void run(const char* name, const ptz::StereoRig& rig, const std::vector<Frame>& frames,
         const perception::Detector& detector, bool windows) {
  perception::WindowParams wp;
  wp.enabled = windows;
  const cv::Size size(rig.left.width, rig.left.height);
  perception::WindowScanner scanner(wp, size, detector.exactMarginPx());
  perception::Tracker tracker;
  std::vector<std::string> names;
  for (const auto& c : detector.params().classes) names.push_back(c.name);
  std::vector<double> all_ms, windowed_ms, full_ms;
  int with_target = 0;
  for (const Frame& f : frames) {
    const auto t0 = Clock::now();
    const ptz::CameraView lv = rig.view(ptz::Side::kLeft, f.left_pose);
    const ptz::CameraView rv = rig.view(ptz::Side::kRight, f.right_pose);
    perception::ScanPlan plan = scanner.plan(tracker.tracks(), f.t_s, lv, rv);
    std::vector<perception::Region> lr, rr;
    std::string why;
    if (!scanner.detect(detector, &plan, decoder(f.left, size), decoder(f.right, size), &lr, &rr,
                        &why)) {
      std::printf("decode failed: %s\n", why.c_str());
      return;
    }
    const auto objects = perception::associate(lr, rr, lv, rv, {});
    tracker.update(f.t_s, perception::trackMeasurements(objects, lr, rr, lv, rv, names, 1.3,
                                                        tracker.tracks(), f.t_s));
    const double t = ms(Clock::now() - t0);
    all_ms.push_back(t);
    (plan.full ? full_ms : windowed_ms).push_back(t);
    for (const auto& o : objects) with_target += o.class_index == 0 ? 1 : 0;
  }
  const std::string what = std::string(name) + (windows ? ", windows on" : ", windows off");
  report((what + ": decode + detect + track").c_str(), all_ms);
  if (windows) {
    if (!windowed_ms.empty()) report("  of which windowed frames", windowed_ms);
    if (!full_ms.empty()) report("  of which full scans", full_ms);
  }
  std::printf("  frames scanned whole %zu of %zu; ball triangulated in %d\n", full_ms.size(),
              all_ms.size(), with_target);
  if (windows) {
    std::printf("  ");
    for (const auto& [k, n] : scanner.counts()) {
      if (n > 0 && k.rfind("full_scans_", 0) == 0)
        std::printf(" %s %lld", k.c_str(), static_cast<long long>(n));
    }
    std::printf(" windows_grown %lld\n",
                static_cast<long long>(scanner.counts().at("windows_grown")));
  }
}

}  // namespace

int main() {
  cv::setNumThreads(1);
  cv::FileStorage sim_cfg(PTZ_SOURCE_DIR "/config/sim_default.yaml", cv::FileStorage::READ);
  cv::FileStorage det_cfg(PTZ_SOURCE_DIR "/config/detect_default.yaml", cv::FileStorage::READ);
  const auto scene = ptz::sim::Scene::fromConfig(sim_cfg["scene"], sim_cfg["objects"],
                                                 sim_cfg["chessboard"], "sim_default.yaml");
  const perception::Detector detector(
      perception::DetectorParams::fromConfig(det_cfg["classes"], "detect_default.yaml"));
  for (const auto& [name, w, h] : {std::tuple<const char*, int, int>{"VGA", 640, 480},
                                   std::tuple<const char*, int, int>{"1080p", 1920, 1080}}) {
    const ptz::StereoRig rig = rigAt(w, h);
    const std::vector<Frame> frames = render(rig, scene);
    run(name, rig, frames, detector, false);
    run(name, rig, frames, detector, true);
  }
  return 0;
}
