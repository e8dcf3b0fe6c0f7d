// Pyramid full scans (perception/detection/pyramid.hpp): at 1080p the reduced image's candidates,
// detected at full resolution in windows around them, give exactly a full-resolution full scan's
// regions (rendered default scenario, JPEG and raw); a region its window cuts grows the window,
// then falls back to a full-resolution scan; an object too small for the reduced image is the
// trade-off; VGA with the default parameters is unchanged; a JPEG decoded reduced by libjpeg is
// libjpeg's scaled size and close to the area average of a full decode.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <memory>

#include "perception/detection/detector.hpp"
#include "perception/detection/pyramid.hpp"
#include "perception/detection/windows.hpp"
#include "perception/jpeg/jpeg_window.hpp"
#include "sim/simulator.hpp"
#include "support/detect_scene.hpp"

using ptz::PtzPose;
using ptz::StereoRig;
namespace perception = ptz::perception;
namespace sim = ptz::sim;
using ptz::test::defaultClasses;
using ptz::test::kGreen;
using ptz::test::kRed;
using ptz::test::object;

namespace {

const StereoRig& rig1080p() {
  static const StereoRig rig = StereoRig::makeDefault().atSize(1920, 1080);
  return rig;
}

sim::Scene defaultScene() {
  cv::FileStorage fs(PTZ_SOURCE_DIR "/config/sim_default.yaml", cv::FileStorage::READ);
  return sim::Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"], "sim_default.yaml");
}

// Both cameras at `pose` (the right one 0.05 rad inwards) at time t_s, motors there at once.
sim::SimFrame render(const StereoRig& rig, const sim::Scene& scene, double t_s,
                     const PtzPose& pose) {
  auto plant = ptz::defaultPlantParams();
  for (auto& a : plant.axis) {
    a.time_constant_s = 1e-4;
    a.max_rate_per_s = 1e6;
  }
  sim::Simulator s(rig, scene, plant, 2.0, 5);
  int clamped = 0, rejected = 0;
  s.command(t_s - 0.05, pose, {pose.pan_rad - 0.05, pose.tilt_rad, pose.zoom}, &clamped, &rejected);
  s.advanceTo(t_s);
  return s.capture();
}

perception::ImagePixels fromMat(const cv::Mat& image) {
  return perception::DecodeParts(
      [image](const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* parts, std::string*) {
        parts->clear();
        for (const auto& r : rects) parts->push_back(image(r).clone());
        return true;
      });
}

// Full scans only (windows off), pyramid above max_width_px (0: never).
std::unique_ptr<perception::WindowScanner> fullScanner(const perception::Detector& detector,
                                                       cv::Size size, int max_width_px) {
  perception::WindowParams wp;
  wp.enabled = false;
  wp.full_scan_max_width_px = max_width_px;
  return std::make_unique<perception::WindowScanner>(wp, size, detector.exactMarginPx());
}

struct Scan {
  std::vector<perception::Region> left, right;
  bool pyramid = false;
};

Scan scan(perception::WindowScanner& scanner, const perception::Detector& detector,
          const perception::ImagePixels& left, const perception::ImagePixels& right) {
  Scan s;
  perception::ScanPlan plan = scanner.plan({}, 0, {}, {});
  std::string why;
  EXPECT_TRUE(scanner.detect(detector, &plan, left, right, &s.left, &s.right, &why)) << why;
  EXPECT_TRUE(plan.full);
  s.pyramid = plan.pyramid;
  return s;
}

void expectSame(const std::vector<perception::Region>& got,
                const std::vector<perception::Region>& want, const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].class_index, want[i].class_index) << what;
    EXPECT_NEAR(got[i].centroid_px.x, want[i].centroid_px.x, 1e-9) << what;
    EXPECT_NEAR(got[i].centroid_px.y, want[i].centroid_px.y, 1e-9) << what;
    EXPECT_EQ(got[i].area_px2, want[i].area_px2) << what;
    EXPECT_EQ(got[i].bbox, want[i].bbox) << what;
    EXPECT_EQ(got[i].shape_distance, want[i].shape_distance) << what;
  }
}

}  // namespace

TEST(Pyramid, ScaleIsTheSmallestPowerOfTwoThatFitsTheWidth) {
  EXPECT_EQ(perception::pyramidScale(640, 960), 1);
  EXPECT_EQ(perception::pyramidScale(960, 960), 1);
  EXPECT_EQ(perception::pyramidScale(961, 960), 2);
  EXPECT_EQ(perception::pyramidScale(1280, 960), 2);
  EXPECT_EQ(perception::pyramidScale(1920, 960), 2);
  EXPECT_EQ(perception::pyramidScale(1920, 480), 4);
  EXPECT_EQ(perception::pyramidScale(3840, 960), 4);
  EXPECT_EQ(perception::pyramidScale(4096, 960), 8);
  EXPECT_EQ(perception::pyramidScale(4096, 100), 8);  // at most 8
  EXPECT_EQ(perception::pyramidScale(1920, 0), 1);    // off
  EXPECT_EQ(perception::reducedSize({1920, 1080}, 2), cv::Size(960, 540));
  EXPECT_EQ(perception::reducedSize({1920, 1080}, 8), cv::Size(240, 135));
  EXPECT_EQ(perception::reducedSize({641, 481}, 4), cv::Size(161, 121));
}

TEST(Pyramid, WindowsAreTheCandidatesScaledBackWithTheMarginCutAndMerged) {
  perception::Region a, b, c;
  a.bbox = {100, 50, 10, 8};
  b.bbox = {104, 52, 10, 8};  // overlaps a once scaled and grown
  c.bbox = {0, 0, 3, 3};      // at the corner: cut to the image
  const auto w = perception::pyramidWindows({a, b, c}, 2, 12, {1920, 1080});
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0], cv::Rect(188, 88, 2 * 14 + 24, 2 * 10 + 24));
  EXPECT_EQ(w[1], cv::Rect(0, 0, 6 + 12, 6 + 12));
  EXPECT_EQ(perception::pyramidMarginPx(2, 6), 18);
}

TEST(Pyramid, AReducedJpegIsLibjpegsScaledSizeAndCloseToTheAreaAverage) {
  const sim::Scene scene = defaultScene();
  const sim::SimFrame f = render(rig1080p(), scene, 3.0, {0, 0.05, 1});
  // 1080p, and an odd size (no whole blocks at the right and bottom).
  cv::Mat odd;
  cv::resize(f.left, odd, {641, 481}, 0, 0, cv::INTER_AREA);
  for (const cv::Mat& image : {f.left, odd}) {
    std::vector<uint8_t> jpeg;
    ASSERT_TRUE(cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90}));
    const cv::Mat whole = cv::imdecode(jpeg, cv::IMREAD_COLOR);
    for (const int s : {2, 4, 8}) {
      cv::Mat reduced;
      std::string why;
      ASSERT_TRUE(perception::decodeJpegReduced(jpeg.data(), jpeg.size(), image.cols, image.rows, s,
                                                &reduced, &why))
          << why;
      const cv::Size want((image.cols + s - 1) / s, (image.rows + s - 1) / s);
      ASSERT_EQ(reduced.size(), want) << s;
      ASSERT_EQ(reduced.type(), CV_8UC3);
      // OpenCV's own reduced decode is libjpeg's with the same settings: the same pixels.
      const int flag = s == 2   ? cv::IMREAD_REDUCED_COLOR_2
                       : s == 4 ? cv::IMREAD_REDUCED_COLOR_4
                                : cv::IMREAD_REDUCED_COLOR_8;
      EXPECT_EQ(cv::norm(reduced, cv::imdecode(jpeg, flag), cv::NORM_INF), 0.0) << s;
      // The area average of the full decode's s x s blocks (a partial block at the right and
      // bottom: its pixels repeated, as the encoder pads a block).
      cv::Mat padded, area;
      cv::copyMakeBorder(whole, padded, 0, want.height * s - whole.rows, 0,
                         want.width * s - whole.cols, cv::BORDER_REPLICATE);
      cv::resize(padded, area, want, 0, 0, cv::INTER_AREA);
      const double mean_abs = cv::norm(reduced, area, cv::NORM_L1) / (reduced.total() * 3.0);
      EXPECT_LT(mean_abs, 0.5) << "scale " << s << " size " << image.size();
    }
  }
  // The header against the message's size, a scale libjpeg's 1/n does not give, grey.
  std::vector<uint8_t> jpeg, gray;
  ASSERT_TRUE(cv::imencode(".jpg", odd, jpeg));
  cv::Mat g, untouched;
  cv::cvtColor(odd, g, cv::COLOR_BGR2GRAY);
  ASSERT_TRUE(cv::imencode(".jpg", g, gray));
  std::string why;
  EXPECT_FALSE(
      perception::decodeJpegReduced(jpeg.data(), jpeg.size(), 640, 481, 2, &untouched, &why));
  EXPECT_NE(why.find("641x481"), std::string::npos) << why;
  EXPECT_FALSE(
      perception::decodeJpegReduced(jpeg.data(), jpeg.size(), 641, 481, 3, &untouched, &why));
  EXPECT_FALSE(perception::decodeJpegReduced(jpeg.data(), 100, 641, 481, 2, &untouched, &why));
  EXPECT_FALSE(
      perception::decodeJpegReduced(gray.data(), gray.size(), 641, 481, 2, &untouched, &why));
  EXPECT_TRUE(untouched.empty());
}

// The default scenario at 1080p at several times and poses (cameras on the ball, looking ahead,
// zoomed in), raw and JPEG: the pyramid's regions are the full-resolution full scan's.
TEST(Pyramid, At1080pItsRegionsAreAFullResolutionFullScans) {
  const StereoRig& rig = rig1080p();
  const perception::Detector detector(defaultClasses());
  const sim::Scene scene = defaultScene();
  const ptz::sim::SceneObject* ball = nullptr;
  for (const auto& o : scene.objects) {
    if (o.class_name == "red_ball") ball = &o;
  }
  ASSERT_NE(ball, nullptr);
  const cv::Size size(rig.left.width, rig.left.height);
  auto full = fullScanner(detector, size, 0);
  auto pyramid = fullScanner(detector, size, 960);
  int frames = 0, regions = 0;
  for (const double t_s : {1.0, 8.0, 16.0, 24.0}) {
    const Eigen::Vector3d p = ball->trajectory.position(t_s);
    const double pan = std::atan2(p.x(), p.z()),
                 tilt = std::atan2(-p.y(), std::hypot(p.x(), p.z()));
    for (const PtzPose& pose : {PtzPose{pan, tilt, 1}, PtzPose{0, 0.1, 1}, PtzPose{pan, tilt, 2}}) {
      const sim::SimFrame f = render(rig, scene, t_s, pose);
      const std::string what = "t " + std::to_string(t_s) + " pan " + std::to_string(pose.pan_rad) +
                               " zoom " + std::to_string(pose.zoom);
      const Scan want = scan(*full, detector, fromMat(f.left), fromMat(f.right));
      EXPECT_FALSE(want.pyramid);
      const Scan raw = scan(*pyramid, detector, fromMat(f.left), fromMat(f.right));
      EXPECT_TRUE(raw.pyramid) << what;
      expectSame(raw.left, want.left, "raw, left, " + what);
      expectSame(raw.right, want.right, "raw, right, " + what);
      std::vector<uint8_t> lj, rj;
      ASSERT_TRUE(cv::imencode(".jpg", f.left, lj, {cv::IMWRITE_JPEG_QUALITY, 90}));
      ASSERT_TRUE(cv::imencode(".jpg", f.right, rj, {cv::IMWRITE_JPEG_QUALITY, 90}));
      const Scan want_jpeg = scan(*full, detector, fromMat(cv::imdecode(lj, cv::IMREAD_COLOR)),
                                  fromMat(cv::imdecode(rj, cv::IMREAD_COLOR)));
      const Scan jpeg = scan(*pyramid, detector, ptz::test::jpegPixels(lj, size),
                             ptz::test::jpegPixels(rj, size));
      EXPECT_TRUE(jpeg.pyramid) << what;
      expectSame(jpeg.left, want_jpeg.left, "JPEG, left, " + what);
      expectSame(jpeg.right, want_jpeg.right, "JPEG, right, " + what);
      ++frames;
      regions += static_cast<int>(want.left.size() + want.right.size());
    }
  }
  // Every object of the scenario in view, the pyramid never handing over to a full-res scan.
  EXPECT_GE(regions, 2 * frames);
  EXPECT_EQ(pyramid->counts().at("frames_scanned_pyramid"), 2 * frames);
  EXPECT_EQ(pyramid->counts().at("frames_scanned_full"), 2 * frames);
  EXPECT_EQ(pyramid->counts().at("pyramid_fallbacks_cut"), 0);
  EXPECT_EQ(pyramid->counts().at("pyramid_fallbacks_cover"), 0);
  EXPECT_EQ(full->counts().at("frames_scanned_pyramid"), 0);
}

// A green square with a thin bar (4 px, which the reduced image's opening removes): the bar's
// region crosses the window of the square; short, the grown window holds it; long, the image is
// scanned at full resolution. Either way the full scan's regions.
TEST(Pyramid, ARegionItsWindowCutsGrowsItOnceThenFallsBackToAFullResolutionScan) {
  const perception::Detector detector(defaultClasses());
  const cv::Size size(1920, 1080);
  for (const auto& [bar_px, grown_holds] : {std::pair<int, bool>{60, true}, {600, false}}) {
    cv::Mat image(size, CV_8UC3, cv::Scalar(90, 90, 90));
    cv::rectangle(image, cv::Rect(800, 400, 100, 100), cv::Scalar(kGreen), cv::FILLED);
    cv::rectangle(image, cv::Rect(900, 448, bar_px, 4), cv::Scalar(kGreen), cv::FILLED);
    auto full = fullScanner(detector, size, 0);
    auto pyramid = fullScanner(detector, size, 960);
    const Scan want = scan(*full, detector, fromMat(image), fromMat(image));
    ASSERT_EQ(want.left.size(), 1u);
    ASSERT_GT(want.left[0].bbox.width, 100 + bar_px / 2) << "the bar is part of the region";
    const Scan got = scan(*pyramid, detector, fromMat(image), fromMat(image));
    expectSame(got.left, want.left, "bar " + std::to_string(bar_px));
    EXPECT_EQ(got.pyramid, grown_holds);
    EXPECT_EQ(pyramid->counts().at("pyramid_windows_grown"), 2);  // both images
    EXPECT_EQ(pyramid->counts().at("frames_scanned_pyramid"), grown_holds ? 1 : 0);
    EXPECT_EQ(pyramid->counts().at("pyramid_fallbacks_cut"), grown_holds ? 0 : 1);
  }
  // Candidates over more than the cover limit: scanned at full resolution.
  perception::WindowParams wp;
  wp.enabled = false;
  wp.max_cover_fraction = 0.001;
  cv::Mat image(size, CV_8UC3, cv::Scalar(90, 90, 90));
  cv::rectangle(image, cv::Rect(800, 400, 100, 100), cv::Scalar(kGreen), cv::FILLED);
  perception::WindowScanner cover(wp, size, detector.exactMarginPx());
  const Scan got = scan(cover, detector, fromMat(image), fromMat(image));
  EXPECT_FALSE(got.pyramid);
  EXPECT_EQ(got.left.size(), 1u);
  EXPECT_EQ(cover.counts().at("pyramid_fallbacks_cover"), 1);
}

// The trade-off: a red ball of 1 cm at 4.5 m (about 35 px^2 at 1080p, above min_area_px2 = 20)
// is found by a full-resolution scan, not in the reduced image (about 9 px^2 there, which the 3x3
// median and opening erase); one of 1.6 cm (about 90 px^2) by both. A sweep of radii at six
// sub-pixel positions: the pyramid finds every ball from about 65 px^2, some at 50, none at 37.
TEST(Pyramid, AnObjectTooSmallForTheReducedImageIsMissedOnlyByThePyramid) {
  const StereoRig& rig = rig1080p();
  const perception::Detector detector(defaultClasses());
  const cv::Size size(rig.left.width, rig.left.height);
  for (const auto& [radius_m, pyramid_finds] :
       {std::pair<double, bool>{0.010, false}, {0.016, true}}) {
    sim::Scene scene;
    sim::SceneObject ball =
        object("red_ball", sim::SceneObject::Shape::kSphere, {0.1, 0.05, 4.5}, kRed);
    ball.radius_m = radius_m;
    scene.objects = {ball};
    const sim::SimFrame f = render(rig, scene, 1.0, {0, 0, 1});
    auto full = fullScanner(detector, size, 0);
    auto pyramid = fullScanner(detector, size, 960);
    const Scan want = scan(*full, detector, fromMat(f.left), fromMat(f.right));
    ASSERT_EQ(want.left.size(), 1u) << radius_m;
    ASSERT_EQ(want.right.size(), 1u) << radius_m;
    const Scan got = scan(*pyramid, detector, fromMat(f.left), fromMat(f.right));
    EXPECT_TRUE(got.pyramid);
    if (pyramid_finds) {
      expectSame(got.left, want.left, "left");
      expectSame(got.right, want.right, "right");
    } else {
      EXPECT_TRUE(got.left.empty()) << want.left[0].area_px2;
      EXPECT_TRUE(got.right.empty()) << want.right[0].area_px2;
    }
  }
}

// VGA with the default parameters: narrower than full_scan_max_width_px, every full scan at full
// resolution, as before.
TEST(Pyramid, VgaWithTheDefaultParametersScansAtFullResolution) {
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  const sim::SimFrame f = render(rig, defaultScene(), 6.0, {0, 0.1, 1});
  const cv::Size size(rig.left.width, rig.left.height);
  perception::WindowParams wp;
  wp.enabled = false;
  ASSERT_EQ(wp.full_scan_max_width_px, 960);
  perception::WindowScanner scanner(wp, size, detector.exactMarginPx());
  const Scan got = scan(scanner, detector, fromMat(f.left), fromMat(f.right));
  EXPECT_FALSE(got.pyramid);
  expectSame(got.left, detector.detect(f.left), "left");
  expectSame(got.right, detector.detect(f.right), "right");
  EXPECT_EQ(scanner.counts().at("frames_scanned_full"), 1);
  EXPECT_EQ(scanner.counts().at("frames_scanned_pyramid"), 0);
}
