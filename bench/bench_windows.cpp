// Windows for speed (perception/detection/windows.hpp, pyramid.hpp): ptz-detect's detection per
// stereo frame (decoding of what is scanned, detection, association, tracking) on rendered frames
// of the default scenario at VGA and 1080p, the cameras following the ball: full scans at full
// resolution against pyramid full scans (JPEG and raw), and windows around the tracked ball with
// either. One core, every frame through every config in turn; median and p99 of decode + detect
// and of the whole, the windowed frames' and full scans' own, the share of frames scanned whole.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "bench_util.hpp"
#include "perception/detection/detector.hpp"
#include "perception/detection/stereo.hpp"
#include "perception/detection/windows.hpp"
#include "perception/jpeg/jpeg_window.hpp"
#include "perception/tracking/tracker.hpp"
#include "sim/simulator.hpp"
#include "support/detect_scene.hpp"

using ptz::bench::Clock;
using ptz::bench::ms;
using ptz::bench::report;
namespace perception = ptz::perception;

namespace {

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
    // As ptz-sim sends them (restart markers splitting every MCU row: jpeg_restart.hpp).
    fr.left = ptz::encodeImage(f.left, ptzstereo::image_t::ENCODING_JPEG, 90).data;
    fr.right = ptz::encodeImage(f.right, ptzstereo::image_t::ENCODING_JPEG, 90).data;
    fr.left_pose = f.left_pose;
    fr.right_pose = f.right_pose;
    fr.t_s = f.t_s;
    frames.push_back(std::move(fr));
  }
  return frames;
}

// A JPEG as ptz-detect reads it: the whole by cv::imdecode, parts by decodeJpegWindows, the
// pyramid's level by decodeJpegReducedRows.
perception::ImagePixels fromJpeg(const std::vector<uint8_t>& jpeg, cv::Size size) {
  perception::ImagePixels pixels = ptz::test::jpegPixels(jpeg, size);
  pixels.parts = [&jpeg, size, parts = pixels.parts](const std::vector<cv::Rect>& rects,
                                                     std::vector<cv::Mat>* out, std::string* why) {
    if (rects.size() == 1 && rects[0] == cv::Rect({0, 0}, size)) {
      out->assign(1, cv::imdecode(jpeg, cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION));
      return !(*out)[0].empty();
    }
    return parts(rects, out, why);
  };
  return pixels;
}

// Raw BGR pixels (ptz-detect's raw frames): parts are views, the level cv::resize INTER_AREA.
perception::ImagePixels fromRaw(const cv::Mat& image) {
  return perception::DecodeParts(
      [&image](const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* parts, std::string*) {
        parts->clear();
        for (const auto& r : rects) parts->push_back(image(r));
        return true;
      });
}

// One way of scanning, with its own scanner and tracker: the frames go through every config in
// turn, so a busy machine slows them alike.
struct Config {
  std::string name;
  perception::WindowParams params;
  bool raw = false;
  std::unique_ptr<perception::WindowScanner> scanner;
  perception::Tracker tracker;
  std::vector<double> detect_ms, all_ms, windowed_ms, full_ms;
  int with_target = 0, pyramid = 0;
};

std::unique_ptr<Config> config(const std::string& name, bool windows, int full_scan_max_width_px,
                               bool raw) {
  auto c = std::make_unique<Config>();
  c->name = name;
  c->params.enabled = windows;
  c->params.full_scan_max_width_px = full_scan_max_width_px;
  c->raw = raw;
  return c;
}

bool step(Config* c, const ptz::StereoRig& rig, const Frame& f, const cv::Mat& left_raw,
          const cv::Mat& right_raw, const perception::Detector& detector,
          const std::vector<std::string>& names) {
  const cv::Size size(rig.left.width, rig.left.height);
  if (!c->scanner) {
    c->scanner =
        std::make_unique<perception::WindowScanner>(c->params, size, detector.exactMarginPx());
  }
  const auto t0 = Clock::now();
  const ptz::CameraView lv = rig.view(ptz::Side::kLeft, f.left_pose);
  const ptz::CameraView rv = rig.view(ptz::Side::kRight, f.right_pose);
  perception::ScanPlan plan = c->scanner->plan(c->tracker.tracks(), f.t_s, lv, rv);
  std::vector<perception::Region> lr, rr;
  std::string why;
  const bool ok = c->raw ? c->scanner->detect(detector, &plan, fromRaw(left_raw),
                                              fromRaw(right_raw), &lr, &rr, &why)
                         : c->scanner->detect(detector, &plan, fromJpeg(f.left, size),
                                              fromJpeg(f.right, size), &lr, &rr, &why);
  if (!ok) {
    std::printf("%s: decode failed: %s\n", c->name.c_str(), why.c_str());
    return false;
  }
  const double detect_ms = ms(Clock::now() - t0);
  const auto objects = perception::associate(lr, rr, lv, rv, {});
  c->tracker.update(f.t_s, perception::trackMeasurements(objects, lr, rr, lv, rv, names, 1.3,
                                                         c->tracker.tracks(), f.t_s));
  const double t = ms(Clock::now() - t0);
  c->detect_ms.push_back(detect_ms);
  c->all_ms.push_back(t);
  (plan.full ? c->full_ms : c->windowed_ms).push_back(t);
  c->pyramid += plan.pyramid ? 1 : 0;
  for (const auto& o : objects) c->with_target += o.class_index == 0 ? 1 : 0;
  return true;
}

void summary(const char* size_name, const Config& c) {
  const std::string what = std::string(size_name) + ", " + c.name;
  std::printf("%s\n", what.c_str());
  report("  decode + detect", c.detect_ms);
  report("  decode + detect + track", c.all_ms);
  if (c.params.enabled) {
    if (!c.windowed_ms.empty()) report("  of which windowed frames", c.windowed_ms);
    if (!c.full_ms.empty()) report("  of which full scans", c.full_ms);
  }
  std::printf(
      "  frames scanned whole %zu of %zu (%d through the pyramid); ball triangulated in %d\n",
      c.full_ms.size(), c.all_ms.size(), c.pyramid, c.with_target);
  std::printf("  ");
  for (const auto& [k, n] : c.scanner->counts()) {
    const bool shown =
        k.rfind("full_scans_", 0) == 0 || k.rfind("pyramid_", 0) == 0 || k == "windows_grown";
    if (n > 0 && shown) std::printf(" %s %lld", k.c_str(), static_cast<long long>(n));
  }
  std::printf("\n");
}

void run(const char* name, const ptz::StereoRig& rig, const std::vector<Frame>& frames,
         const perception::Detector& detector) {
  // The pyramid at VGA (to 320 px, by 2) only to compare: its default (960) leaves VGA alone.
  const int pyramid_px = rig.left.width > 960 ? 960 : 320;
  std::vector<std::unique_ptr<Config>> configs;
  configs.push_back(config("full scans, full resolution, JPEG", false, 0, false));
  configs.push_back(config("full scans, pyramid " + std::to_string(pyramid_px) + " px, JPEG", false,
                           pyramid_px, false));
  configs.push_back(config("full scans, full resolution, raw", false, 0, true));
  configs.push_back(config("full scans, pyramid " + std::to_string(pyramid_px) + " px, raw", false,
                           pyramid_px, true));
  configs.push_back(config("windows on, full scans at full resolution, JPEG", true, 0, false));
  configs.push_back(
      config("windows on, full scans pyramid " + std::to_string(pyramid_px) + " px, JPEG", true,
             pyramid_px, false));
  if (rig.left.width > 960) {  // a quarter of 1080p's width
    configs.push_back(config("windows on, full scans pyramid 480 px, JPEG", true, 480, false));
  }
  std::vector<std::string> names;
  for (const auto& c : detector.params().classes) names.push_back(c.name);
  for (const Frame& f : frames) {
    // Raw frames as the camera would send them (decoded outside the timing).
    const cv::Mat left_raw = cv::imdecode(f.left, cv::IMREAD_COLOR);
    const cv::Mat right_raw = cv::imdecode(f.right, cv::IMREAD_COLOR);
    for (auto& c : configs) {
      if (!step(c.get(), rig, f, left_raw, right_raw, detector, names)) return;
    }
  }
  for (const auto& c : configs) summary(name, *c);
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
    const ptz::StereoRig rig = ptz::StereoRig::makeDefault().atSize(w, h);
    const std::vector<Frame> frames = render(rig, scene);
    run(name, rig, frames, detector);
  }
  return 0;
}
