// The cost of each detector of ptz-detect per stereo frame (both images), one core, on rendered
// frames of config/sim_markers.yaml (a tagged cube turning, a loose ArUco tag, the red ball) at
// VGA and 1080p: the colour classes (the baseline of the same run), libapriltag and ArUco on whole
// images and on a window around the cube, the pose of the tagged objects from both views, and the
// clicked object's search in both views. Medians and p99.
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <string>
#include <vector>

#include "bench_scene.hpp"
#include "bench_util.hpp"
#include "common/measure.hpp"
#include "perception/appearance/clicked.hpp"
#include "perception/detection/detector.hpp"
#include "perception/markers/marker_pose.hpp"

using ptz::bench::Clock;
using ptz::bench::ms;
using ptz::bench::report;
namespace perception = ptz::perception;

namespace {

void run(const char* size_name, int width, int height) {
  ptz::bench::BenchScene bench("sim_markers.yaml", width, height);
  cv::FileStorage mk_cfg(PTZ_SOURCE_DIR "/config/markers_tool.yaml", cv::FileStorage::READ);
  std::string why;
  const auto classes = perception::markerClassesFromConfig(mk_cfg["markers"], "markers_tool.yaml");
  std::vector<perception::MarkerClass> april, aruco;
  for (const auto& c : classes) (c.detector == "apriltag" ? april : aruco).push_back(c);
  perception::MarkerDetector april_l(april), april_r(april), aruco_l(aruco), aruco_r(aruco);
  std::vector<double> colour_ms, april_ms, april_window_ms, aruco_ms, aruco_window_ms, pose_ms,
      click_ms;
  perception::ClickedTracker clicked;
  int tags = 0;
  for (int i = 0; i < 60; ++i) {
    ptz::CameraView lv, rv;
    const ptz::sim::SimFrame f = bench.frameAt(i / 30.0, &lv, &rv);
    auto t0 = Clock::now();
    bench.colours.detect(f.left);
    bench.colours.detect(f.right);
    colour_ms.push_back(ms(Clock::now() - t0));
    t0 = Clock::now();
    const auto al = april_l.detect(f.left, {0, 0}, nullptr, 1.5);
    const auto ar = april_r.detect(f.right, {0, 0}, nullptr, 1.5);
    april_ms.push_back(ms(Clock::now() - t0));
    t0 = Clock::now();
    aruco_l.detect(f.left, {0, 0});
    aruco_r.detect(f.right, {0, 0});
    aruco_ms.push_back(ms(Clock::now() - t0));
    t0 = Clock::now();
    std::vector<std::string> failed;
    const auto objects = perception::markerObjects(april, al, ar, lv, rv, {}, &failed);
    pose_ms.push_back(ms(Clock::now() - t0));
    tags += static_cast<int>(al.size());
    // A window around the cube in each view, as a tracked tag is looked for.
    const Eigen::Vector3d cube = bench.scene.objects[0].trajectory.position(i / 30.0);
    t0 = Clock::now();
    for (int s = 0; s < 2; ++s) {
      const ptz::CameraView& v = s == 0 ? lv : rv;
      const Eigen::Vector2d c = v.project(cube);
      const int half = static_cast<int>(v.intrinsics.fx * 0.3 / cube.z());
      const cv::Rect w = cv::Rect(static_cast<int>(c.x()) - half, static_cast<int>(c.y()) - half,
                                  2 * half, 2 * half) &
                         cv::Rect(0, 0, width, height);
      (s == 0 ? april_l : april_r).detect((s == 0 ? f.left : f.right)(w), w.tl(), nullptr, 1);
    }
    april_window_ms.push_back(ms(Clock::now() - t0));
    // A window around the loose ArUco tag, as large as a tracked one's (its plate's radius and
    // ptz-detect's 16 px margin).
    const Eigen::Vector3d plate = bench.scene.objects[1].trajectory.position(i / 30.0);
    t0 = Clock::now();
    for (int s = 0; s < 2; ++s) {
      const ptz::CameraView& v = s == 0 ? lv : rv;
      const Eigen::Vector2d c = v.project(plate);
      const int half = static_cast<int>(v.intrinsics.fx * 0.16 / plate.z()) + 16;
      const cv::Rect w = cv::Rect(static_cast<int>(c.x()) - half, static_cast<int>(c.y()) - half,
                                  2 * half, 2 * half) &
                         cv::Rect(0, 0, width, height);
      (s == 0 ? aruco_l : aruco_r).detect((s == 0 ? f.left : f.right)(w), w.tl(), nullptr, 1);
    }
    aruco_window_ms.push_back(ms(Clock::now() - t0));
    // The click: on the cube in the first frame, then found in both views each frame.
    cv::Mat images[2] = {f.left, f.right};
    const perception::CropPixels crops[2] = {[&](const cv::Rect& r, cv::Mat* out, std::string*) {
                                               *out = images[0](r);
                                               return true;
                                             },
                                             [&](const cv::Rect& r, cv::Mat* out, std::string*) {
                                               *out = images[1](r);
                                               return true;
                                             }};
    if (i == 0) {
      perception::PatchObject first;
      clicked.start(ptz::Side::kLeft, lv.project(cube), crops, lv, rv, &first, &why);
      continue;
    }
    t0 = Clock::now();
    clicked.find(nullptr, i / 30.0, crops, lv, rv, &why);
    click_ms.push_back(ms(Clock::now() - t0));
  }
  std::printf("-- %s (%d x %d), per stereo frame, one core; %d tags seen in the left images\n",
              size_name, width, height, tags);
  report("colour classes, whole images (baseline)", colour_ms);
  report("libapriltag, whole images (decimate 1.5)", april_ms);
  report("libapriltag, a window around the cube", april_window_ms);
  report("ArUco, whole images", aruco_ms);
  report("ArUco, a window around the loose tag", aruco_window_ms);
  report("tagged objects' poses from both views", pose_ms);
  report("clicked object, found in both views", click_ms);
  ptz::bench::reportRatio("libapriltag whole / colour", april_ms, colour_ms);
}

}  // namespace

int main() {
  return ptz::bench::runAtVgaAnd1080p(run);
}
