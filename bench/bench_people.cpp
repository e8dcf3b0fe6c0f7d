// The cost of ptz-detect's face and person detectors per stereo frame, one core, on rendered
// frames of config/sim_people.yaml (a figure walking across at 3.5 m, a face printed on a card at
// 1.5 m, the red ball) at VGA and 1080p, with config/people.yaml's classes: the colour classes
// (the baseline of the same run), OpenCV's HOG people detector and the face cascade on the whole
// left image at their classes' scan scales, and PeopleScanner's frame (one strip, the classes
// taking turns; with and without a track on the walker, whose window it then adds). Medians, p99.
// At 1080p the rig's field is as wide as at VGA but a quarter less tall: the walker's feet leave
// the frame, and HOG, which needs the whole figure, finds it in about half the frames.
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>

#include <cstdio>
#include <string>
#include <vector>

#include "bench_scene.hpp"
#include "bench_util.hpp"
#include "common/measure.hpp"
#include "perception/detection/detector.hpp"
#include "perception/people/people_scan.hpp"

namespace ptz::bench {
namespace {

void run(const char* size_name, int width, int height) {
  BenchScene bench("sim_people.yaml", width, height);
  cv::FileStorage people_cfg(PTZ_SOURCE_DIR "/config/people.yaml", cv::FileStorage::READ);
  const auto classes = perception::peopleClassesFromConfig(people_cfg["people"], "people.yaml");
  const perception::PeopleClass& person = classes.at(0);
  const perception::PeopleClass& face = classes.at(1);
  cv::HOGDescriptor hog;
  hog.setSVMDetector(cv::HOGDescriptor::getDefaultPeopleDetector());
  cv::CascadeClassifier cascade;
  perception::loadCascade(face.cascade, &cascade);
  perception::PeopleScanner strips_only(classes, {}, {width, height});
  perception::PeopleScanner with_track(classes, {}, {width, height});
  std::vector<double> colour_ms, hog_ms, cascade_ms, strip_ms, tracked_ms;
  std::vector<double> strip_class_ms[2],
      window_ms;  // frames whose strip was the person's, the face's
  int objects_found = 0, walker_found = 0;
  constexpr int kFrames = 48;  // 4 times round the 6 strips of both classes
  for (int i = 0; i < kFrames; ++i) {
    const double t_s = i / 30.0;
    ptz::CameraView lv, rv;
    const ptz::sim::SimFrame f = bench.frameAt(t_s, &lv, &rv);
    auto t0 = Clock::now();
    bench.colours.detect(f.left);
    bench.colours.detect(f.right);
    colour_ms.push_back(ms(Clock::now() - t0));
    cv::Mat grey, reduced;
    t0 = Clock::now();
    cv::cvtColor(f.left, grey, cv::COLOR_BGR2GRAY);
    cv::resize(grey, reduced, {}, person.scan_scale, person.scan_scale, cv::INTER_AREA);
    std::vector<cv::Rect> found;
    hog.detectMultiScale(reduced, found);
    hog_ms.push_back(ms(Clock::now() - t0));
    t0 = Clock::now();
    cv::cvtColor(f.left, grey, cv::COLOR_BGR2GRAY);
    cv::resize(grey, reduced, {}, face.scan_scale, face.scan_scale, cv::INTER_AREA);
    cascade.detectMultiScale(reduced, found, 1.2, face.min_neighbors, 0,
                             cv::Size(face.min_box_px, face.min_box_px));
    cascade_ms.push_back(ms(Clock::now() - t0));
    cv::Mat images[2] = {f.left, f.right};
    const perception::CropPixels crops[2] = {[&](const cv::Rect& r, cv::Mat* out, std::string*) {
                                               *out = images[0](r);
                                               return true;
                                             },
                                             [&](const cv::Rect& r, cv::Mat* out, std::string*) {
                                               *out = images[1](r);
                                               return true;
                                             }};
    std::vector<perception::PatchObject> objects;
    std::string why;
    t0 = Clock::now();
    strips_only.scan({}, t_s, lv, rv, crops, &objects, &why);
    strip_ms.push_back(ms(Clock::now() - t0));
    strip_class_ms[i % 2].push_back(strip_ms.back());  // the two classes take turns
    objects_found += static_cast<int>(objects.size());
    // The walker tracked where it is (5 cm spread), as the tracker would predict it.
    std::vector<perception::Track> tracks(1);
    tracks[0].class_name = person.name;
    tracks[0].x.head<3>() = bench.scene.objects[0].trajectory.position(t_s);
    tracks[0].P = Eigen::Matrix<double, 9, 9>::Identity() * 0.0025;
    tracks[0].t_s = t_s;
    t0 = Clock::now();
    with_track.scan(tracks, t_s, lv, rv, crops, &objects, &why);
    tracked_ms.push_back(ms(Clock::now() - t0));
    window_ms.push_back(tracked_ms.back() - strip_ms.back());  // the same strip in both
    for (const auto& o : objects) walker_found += o.class_name == person.name;
  }
  std::printf(
      "-- %s (%d x %d), per stereo frame, one core; strips found %d objects, the tracked walker "
      "found in %d of %d frames\n",
      size_name, width, height, objects_found, walker_found, kFrames);
  std::printf("  the tracked scanner's counts:");
  for (const auto& [name, n] : with_track.counts())
    std::printf(" %s %lld", name.c_str(), static_cast<long long>(n));
  std::printf("\n");
  report("colour classes, both images (baseline)", colour_ms);
  report("HOG people, whole left image (scale 0.5)", hog_ms);
  report("face cascade, whole left image (scale 0.75)", cascade_ms);
  report("people scan: one strip a frame, no track", strip_ms);
  report("  ... frames of a person strip (HOG)", strip_class_ms[0]);
  report("  ... frames of a face strip (cascade)", strip_class_ms[1]);
  report("people scan: the same + the walker's window", tracked_ms);
  report("  ... the walker's window alone (the difference)", window_ms);
  reportRatio("people scan with the walker / colour", tracked_ms, colour_ms);
}

}  // namespace
}  // namespace ptz::bench

int main() {
  return ptz::bench::runAtVgaAnd1080p(ptz::bench::run);
}
