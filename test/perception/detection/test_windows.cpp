// Windows for speed: rectangles from known projections, merging, the reasons for a full scan,
// regions in a window exactly a full scan's, a JPEG's part decoded exactly as the same part of a
// full decode, and a new object away from the windows found by the next full scan.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <random>
#include <stdexcept>
#include <thread>
#include <vector>

#include "common/transport/transport.hpp"
#include "perception/detection/detector.hpp"
#include "perception/detection/stereo.hpp"
#include "perception/detection/windows.hpp"
#include "perception/jpeg/jpeg_window.hpp"
#include "perception/tracking/tracker.hpp"
#include "sim/simulator.hpp"
#include "support/detect_scene.hpp"

using ptz::CameraView;
using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace perception = ptz::perception;
namespace sim = ptz::sim;
using ptz::test::defaultClasses;
using ptz::test::kGreen;
using ptz::test::kRed;
using ptz::test::object;

namespace {

// A pinhole camera at the head's origin looking along +z, no distortion.
CameraView pinhole() {
  CameraView v;
  v.width = 640;
  v.height = 480;
  v.intrinsics.fx = 500;
  v.intrinsics.fy = 520;
  v.intrinsics.cx = 320;
  v.intrinsics.cy = 240;
  return v;
}

perception::Track confirmedAt(const Eigen::Vector3d& p, double radius_m, double sigma_m) {
  perception::Track t;
  t.id = 1;
  t.class_name = "red_ball";
  t.state = perception::TrackState::kConfirmed;
  t.x.head<3>() = p;
  t.P = Eigen::Matrix<double, 9, 9>::Identity() * 1e-6;
  t.P.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * sigma_m * sigma_m;
  t.radius_m = radius_m;
  return t;
}

const cv::Vec3b kBlue(200, 60, 30);

// A simulator whose motors reach the pose at once.
std::unique_ptr<sim::Simulator> simulator(const StereoRig& rig, const sim::Scene& scene,
                                          const PtzPose& pose) {
  auto plant = ptz::defaultPlantParams();
  for (auto& a : plant.axis) {
    a.time_constant_s = 1e-4;
    a.max_rate_per_s = 1e6;
  }
  auto s = std::make_unique<sim::Simulator>(rig, scene, plant, 2.0, 3);
  int clamped = 0, rejected = 0;
  s->command(0, pose, pose, &clamped, &rejected);
  s->advanceTo(0.05);
  return s;
}

void expectSame(const std::vector<perception::Region>& a, const std::vector<perception::Region>& b,
                const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  for (size_t i = 0; i < a.size(); ++i) {
    // Bit for bit: the same pixels give the same numbers.
    EXPECT_EQ(a[i].class_index, b[i].class_index) << what;
    EXPECT_EQ(a[i].centroid_px.x, b[i].centroid_px.x) << what;
    EXPECT_EQ(a[i].centroid_px.y, b[i].centroid_px.y) << what;
    EXPECT_EQ(a[i].area_px2, b[i].area_px2) << what;
    EXPECT_EQ(a[i].bbox, b[i].bbox) << what;
    EXPECT_EQ(a[i].shape_distance, b[i].shape_distance) << what;
    EXPECT_EQ(a[i].elongation, b[i].elongation) << what;
  }
}

perception::DecodeParts fromMat(const cv::Mat& image) {
  return [image](const std::vector<cv::Rect>& rects, std::vector<cv::Mat>* parts, std::string*) {
    parts->clear();
    for (const auto& r : rects) parts->push_back(image(r).clone());
    return true;
  };
}

}  // namespace

TEST(Windows, RectangleIsTheProjectedCubeOfTheSphereAndTheMargin) {
  const CameraView v = pinhole();
  const Eigen::Vector3d p(0.2, -0.1, 2.0);
  const double r = 0.1, margin = 5;
  cv::Rect rect;
  ASSERT_TRUE(perception::projectSphere(v, p, r, margin, &rect));
  // x: (x - r) / (z + r) is the leftmost corner, (x + r) / (z - r) the rightmost; y: (y - r) /
  // (z - r) the top (negative), (y + r) = 0 the bottom at any depth.
  const double x0 = 320 + 500 * 0.1 / 2.1 - margin, x1 = 320 + 500 * 0.3 / 1.9 + margin;
  const double y0 = 240 + 520 * -0.2 / 1.9 - margin, y1 = 240 + 520 * 0.0 + margin;
  EXPECT_EQ(rect.x, static_cast<int>(std::floor(x0)));
  EXPECT_EQ(rect.y, static_cast<int>(std::floor(y0)));
  EXPECT_EQ(rect.br().x - 1, static_cast<int>(std::ceil(x1)));
  EXPECT_EQ(rect.br().y - 1, static_cast<int>(std::ceil(y1)));
  // Behind the camera, or reaching to its plane: no window.
  EXPECT_FALSE(perception::projectSphere(v, {0, 0, -2}, r, margin, &rect));
  EXPECT_FALSE(perception::projectSphere(v, {0, 0, 0.05}, r, margin, &rect));
  EXPECT_FALSE(perception::projectSphere(v, {0, 0, NAN}, r, margin, &rect));
}

TEST(Windows, TrackWindowIsItsPredictionWithRadiusPlusKSigma) {
  const CameraView v = pinhole();
  perception::WindowParams p;
  p.sigma_scale = 3;
  p.margin_px = 8;
  perception::Track t = confirmedAt({0.1, 0.0, 3.0}, 0.1, 0.02);
  t.x.segment<3>(3) = Eigen::Vector3d(0.6, 0, 0);  // moving right at 0.6 m/s
  t.t_s = 1.0;
  cv::Rect got, want;
  ASSERT_TRUE(perception::trackWindow(v, t, 1.0, p, &got));
  ASSERT_TRUE(perception::projectSphere(v, {0.1, 0, 3}, 0.1 + 3 * 0.02, 8, &want));
  EXPECT_EQ(got, want);
  // 0.1 s later: 6 cm to the right, sigma grown by the velocity's (1e-3 m/s) share.
  ASSERT_TRUE(perception::trackWindow(v, t, 1.1, p, &got));
  const double sigma = std::sqrt(0.02 * 0.02 + 0.1 * 0.1 * 1e-6 + std::pow(0.005, 2) * 1e-6);
  ASSERT_TRUE(perception::projectSphere(v, {0.16, 0, 3}, 0.1 + 3 * sigma, 8, &want));
  EXPECT_EQ(got, want);
  t.radius_m = 0;  // unknown radius: no window
  EXPECT_FALSE(perception::trackWindow(v, t, 1.0, p, &got));
}

TEST(Windows, OverlappingAndTouchingRectanglesMerge) {
  using R = cv::Rect;
  EXPECT_EQ(perception::mergeRects({R(0, 0, 10, 10), R(50, 50, 10, 10)}).size(), 2u);
  EXPECT_EQ(perception::mergeRects({R(0, 0, 10, 10), R(5, 5, 10, 10)}),
            std::vector<R>{R(0, 0, 15, 15)});
  EXPECT_EQ(perception::mergeRects({R(0, 0, 10, 10), R(10, 0, 10, 10)}),
            std::vector<R>{R(0, 0, 20, 10)});
  // A chain: the first two merge into a box that then overlaps the third.
  EXPECT_EQ(perception::mergeRects({R(0, 0, 10, 10), R(30, 12, 10, 10), R(8, 8, 24, 4)}),
            std::vector<R>{R(0, 0, 40, 22)});
}

TEST(Windows, FullScanReasons) {
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  const CameraView lv = rig.view(Side::kLeft, {0, 0, 1}), rv = rig.view(Side::kRight, {0, 0, 1});
  const cv::Size size(rig.left.width, rig.left.height);
  const cv::Mat black(size, CV_8UC3, cv::Scalar::all(0));
  std::vector<perception::Region> l, r;
  std::string why;
  perception::WindowParams wp;
  wp.full_scan_every = 3;
  wp.full_scan_in_bands = false;
  {
    perception::WindowParams off = wp;
    off.enabled = false;
    perception::WindowScanner s(off, size, detector.exactMarginPx());
    EXPECT_EQ(s.plan({confirmedAt({0, 0, 3}, 0.1, 0.01)}, 0, lv, rv).reason, "disabled");
  }
  perception::WindowScanner s(wp, size, detector.exactMarginPx());
  EXPECT_EQ(s.plan({}, 0, lv, rv).reason, "no_tracks");
  perception::Track tentative = confirmedAt({0, 0, 3}, 0.1, 0.01);
  tentative.state = perception::TrackState::kTentative;
  EXPECT_EQ(s.plan({tentative}, 0, lv, rv).reason, "no_tracks");
  EXPECT_EQ(s.plan({confirmedAt({0, 0, -3}, 0.1, 0.01)}, 0, lv, rv).reason, "behind");
  {
    // Across the image's border: the window is cut to the image (its edge is exact there).
    const perception::ScanPlan b = s.plan({confirmedAt({1.9, 0, 3}, 0.1, 0.01)}, 0, lv, rv);
    EXPECT_FALSE(b.full) << b.reason;
    ASSERT_EQ(b.left.size(), 1u);
    EXPECT_EQ(b.left[0].br().x, size.width);
  }
  {
    perception::WindowParams small = wp;
    small.max_cover_fraction = 0.001;
    perception::WindowScanner c(small, size, detector.exactMarginPx());
    EXPECT_EQ(c.plan({confirmedAt({0, 0, 3}, 0.1, 0.01)}, 0, lv, rv).reason, "cover");
  }
  // Windowed, then every third frame whole.
  const std::vector<perception::Track> tracks = {confirmedAt({0, 0, 3}, 0.1, 0.01)};
  std::vector<std::string> reasons;
  for (int i = 0; i < 6; ++i) {
    perception::ScanPlan plan = s.plan(tracks, 0, lv, rv);
    ASSERT_TRUE(s.detect(detector, &plan, fromMat(black), fromMat(black), &l, &r, &why)) << why;
    reasons.push_back(plan.full ? plan.reason : "windowed");
  }
  EXPECT_EQ(reasons, (std::vector<std::string>{"windowed", "windowed", "periodic", "windowed",
                                               "windowed", "periodic"}));
  EXPECT_EQ(s.counts().at("frames_scanned_windowed"), 4);
  EXPECT_EQ(s.counts().at("frames_scanned_full"), 2);
  EXPECT_EQ(s.counts().at("full_scans_periodic"), 2);
  EXPECT_EQ(s.counts().at("bands_scanned"), 0);

  // In bands: every frame windowed, with band k mod 3 of the rows, each reaching 5 % of the
  // height (24 px) into its neighbours.
  perception::WindowParams banded = wp;
  banded.full_scan_in_bands = true;
  perception::WindowScanner b(banded, size, detector.exactMarginPx());
  std::vector<cv::Rect> bands;
  for (int i = 0; i < 4; ++i) {
    perception::ScanPlan plan = b.plan(tracks, 0, lv, rv);
    ASSERT_TRUE(b.detect(detector, &plan, fromMat(black), fromMat(black), &l, &r, &why)) << why;
    EXPECT_FALSE(plan.full) << plan.reason;
    bands.push_back(plan.band);
  }
  EXPECT_EQ(bands,
            (std::vector<cv::Rect>{
                {0, 0, 640, 184}, {0, 136, 640, 208}, {0, 296, 640, 184}, {0, 0, 640, 184}}));
  EXPECT_EQ(b.counts().at("bands_scanned"), 4);
  EXPECT_EQ(b.counts().at("frames_scanned_full"), 0);
}

TEST(Windows, RegionsInsideAWindowAreExactlyAFullScans) {
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  sim::Scene scene;
  // A green box cut by the image's left border: windows there are cut to the image.
  scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, {0.1, 0.05, 2.5}, kRed),
                   object("green_box", sim::SceneObject::Shape::kBox, {-1.8, 0.1, 2.5}, kGreen),
                   object("blue_ball", sim::SceneObject::Shape::kSphere, {0.5, -0.2, 2}, kBlue)};
  const sim::SimFrame f = simulator(rig, scene, {0, 0, 1})->capture();
  const cv::Size size = f.left.size();
  const std::vector<perception::Region> full = detector.detect(f.left);
  ASSERT_EQ(full.size(), 3u);
  ASSERT_EQ(full[1].bbox.x, 0) << "the box should touch the left border";
  const int margin = detector.exactMarginPx();
  std::mt19937 rng(7);
  int checked = 0;
  for (const auto& region : full) {
    for (int k = 0; k < 20; ++k) {
      // A window around the region at random slack (2..30 px each side), cut to the image; the
      // crop its margin.
      std::uniform_int_distribution<int> slack(2, 30);
      const int a = slack(rng), b = slack(rng), c = slack(rng), d = slack(rng);
      const cv::Rect window = cv::Rect(region.bbox.x - a, region.bbox.y - b,
                                       region.bbox.width + a + c, region.bbox.height + b + d) &
                              cv::Rect({0, 0}, size);
      const cv::Rect crop = cv::Rect(window.x - margin, window.y - margin,
                                     window.width + 2 * margin, window.height + 2 * margin) &
                            cv::Rect({0, 0}, size);
      bool cut = true;
      const auto got = detector.detectWindow(f.left(crop).clone(), crop.tl(), window, size, &cut);
      std::vector<perception::Region> want;
      for (const auto& r : full) {
        if ((r.bbox & window) == r.bbox) want.push_back(r);
      }
      expectSame(got, want, "window " + std::to_string(window.x) + "," + std::to_string(window.y));
      EXPECT_FALSE(cut);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 60);
  // A window that cuts the ball: the ball is not reported, and the cut is.
  const cv::Rect ball = full[0].bbox;
  const cv::Rect half(ball.x + ball.width / 2, ball.y - 10, ball.width, ball.height + 20);
  const cv::Rect crop(half.x - margin, half.y - margin, half.width + 2 * margin,
                      half.height + 2 * margin);
  bool cut = false;
  EXPECT_TRUE(detector.detectWindow(f.left(crop).clone(), crop.tl(), half, size, &cut).empty());
  EXPECT_TRUE(cut);
}

TEST(Windows, AJpegWindowIsExactlyThatPartOfAFullDecode) {
  const StereoRig rig = StereoRig::makeDefault();
  sim::Scene scene;
  scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, {0.1, 0.05, 2.5}, kRed)};
  const sim::SimFrame f = simulator(rig, scene, {0, 0, 1})->capture();
  const std::vector<std::vector<int>> settings = {
      {cv::IMWRITE_JPEG_QUALITY, 90},
      {cv::IMWRITE_JPEG_QUALITY, 75, cv::IMWRITE_JPEG_PROGRESSIVE, 1},
      {cv::IMWRITE_JPEG_QUALITY, 90, cv::IMWRITE_JPEG_RST_INTERVAL, 4},
      {cv::IMWRITE_JPEG_QUALITY, 95, cv::IMWRITE_JPEG_OPTIMIZE, 1}};
  const std::vector<cv::Rect> rects = {{0, 0, 640, 480},  {0, 0, 17, 9},    {623, 471, 17, 9},
                                       {16, 16, 32, 32},  {7, 13, 101, 77}, {301, 229, 55, 61},
                                       {0, 200, 640, 33}, {333, 0, 1, 480}, {250, 101, 230, 1}};
  for (const auto& s : settings) {
    std::vector<uint8_t> jpeg;
    ASSERT_TRUE(cv::imencode(".jpg", f.left, jpeg, s));
    const cv::Mat whole = cv::imdecode(jpeg, cv::IMREAD_COLOR);
    for (const auto& r : rects) {
      cv::Mat part;
      std::string why;
      ASSERT_TRUE(perception::decodeJpegWindow(jpeg.data(), jpeg.size(), 640, 480, r, &part, &why))
          << why;
      ASSERT_EQ(part.size(), r.size());
      EXPECT_EQ(cv::norm(part, whole(r), cv::NORM_INF), 0.0)
          << "rect " << r << " settings " << s[1];
    }
    // All of them in one pass: the same pixels.
    std::vector<cv::Mat> parts;
    std::string why_all;
    ASSERT_TRUE(
        perception::decodeJpegWindows(jpeg.data(), jpeg.size(), 640, 480, rects, &parts, &why_all))
        << why_all;
    ASSERT_EQ(parts.size(), rects.size());
    for (size_t i = 0; i < rects.size(); ++i) {
      EXPECT_EQ(cv::norm(parts[i], whole(rects[i]), cv::NORM_INF), 0.0)
          << "one pass, rect " << rects[i] << " settings " << s[1];
    }
    // Gaps that start and end inside row groups (odd rows), and one of a single row.
    const std::vector<cv::Rect> apart = {{400, 300, 40, 30}, {20, 20, 30, 30},  {300, 100, 8, 150},
                                         {5, 257, 33, 1},    {101, 263, 7, 13}, {60, 291, 9, 3}};
    ASSERT_TRUE(
        perception::decodeJpegWindows(jpeg.data(), jpeg.size(), 640, 480, apart, &parts, &why_all))
        << why_all;
    for (size_t i = 0; i < apart.size(); ++i) {
      EXPECT_EQ(cv::norm(parts[i], whole(apart[i]), cv::NORM_INF), 0.0)
          << "one pass, rect " << apart[i] << " settings " << s[1];
    }
    // The header against the message's size, and rectangles outside, before anything is decoded.
    cv::Mat untouched;
    std::string why;
    EXPECT_FALSE(perception::decodeJpegWindow(jpeg.data(), jpeg.size(), 640, 479, {0, 0, 8, 8},
                                              &untouched, &why));
    EXPECT_NE(why.find("640x480"), std::string::npos) << why;
    EXPECT_FALSE(perception::decodeJpegWindow(jpeg.data(), jpeg.size(), 640, 480, {630, 0, 20, 8},
                                              &untouched, &why));
    EXPECT_FALSE(
        perception::decodeJpegWindow(jpeg.data(), 100, 640, 480, {0, 0, 8, 8}, &untouched, &why));
    EXPECT_TRUE(untouched.empty());
  }
  std::vector<uint8_t> gray;
  cv::Mat g;
  cv::cvtColor(f.left, g, cv::COLOR_BGR2GRAY);
  ASSERT_TRUE(cv::imencode(".jpg", g, gray));
  cv::Mat part;
  std::string why;
  EXPECT_FALSE(
      perception::decodeJpegWindow(gray.data(), gray.size(), 640, 480, {0, 0, 8, 8}, &part, &why));
}

// The loop's detection on a static scene: the red ball is tracked, windows follow it; a green box
// appears away from them at frame `appear`; the next full scan (within full_scan_every frames)
// finds it. Windowed frames give exactly the full scan's regions of the ball.
// Whole every n-th frame, or a band a frame: the box is found within n frames of appearing; in
// bands, in a windowed frame, exactly as a full scan finds it; a band searched on its own after the
// frame's windows (ptz-detect's search for new objects) finds it as exactly, and the frame's
// windows only the ball.
enum class NewObjects { kWholeFrames, kBands, kBandAfter };
void findsANewObject(NewObjects mode) {
  const bool in_bands = mode != NewObjects::kWholeFrames;
  SCOPED_TRACE(mode == NewObjects::kWholeFrames ? "whole every n-th frame"
               : mode == NewObjects::kBands     ? "in bands"
                                                : "band after the windows");
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  const std::vector<std::string> names = {"red_ball", "green_box", "blue_ball"};
  const PtzPose pose{0, 0, 1};
  sim::Scene before, after;
  before.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, {0.1, 0.05, 2.5}, kRed)};
  after.objects = before.objects;
  after.objects.push_back(
      object("green_box", sim::SceneObject::Shape::kBox, {-0.6, -0.2, 3}, kGreen));
  auto sim_before = simulator(rig, before, pose), sim_after = simulator(rig, after, pose);
  perception::WindowParams wp;
  wp.full_scan_every = 5;
  wp.full_scan_in_bands = in_bands;
  perception::WindowScanner scanner(wp, {rig.left.width, rig.left.height},
                                    detector.exactMarginPx());
  perception::Tracker tracker;
  const CameraView lv = rig.view(Side::kLeft, pose), rv = rig.view(Side::kRight, pose);
  const int appear = 12;
  int found_at = -1, windowed = 0;
  for (int i = 0; i < 30 && found_at < 0; ++i) {
    const double t = 0.1 + i / 30.0;
    sim::Simulator& s = i < appear ? *sim_before : *sim_after;
    s.advanceTo(t);
    const sim::SimFrame f = s.capture();
    perception::ScanPlan plan = scanner.plan(tracker.tracks(), t, lv, rv);
    cv::Rect band;
    if (mode == NewObjects::kBandAfter) std::swap(band, plan.band);
    std::vector<perception::Region> lr, rr;
    std::string why;
    ASSERT_TRUE(scanner.detect(detector, &plan, fromMat(f.left), fromMat(f.right), &lr, &rr, &why))
        << why;
    if (mode == NewObjects::kBandAfter && !plan.full) {
      const std::vector<cv::Rect> tracked[2] = {plan.left, plan.right};
      std::vector<perception::Region> bl, br;
      ASSERT_TRUE(scanner.detectBand(detector, band, tracked, fromMat(f.left), fromMat(f.right),
                                     &bl, &br, &why))
          << why;
      const auto box = [](std::vector<perception::Region> v) {
        v.erase(
            std::remove_if(v.begin(), v.end(), [](const auto& r) { return r.class_index != 1; }),
            v.end());
        return v;
      };
      if (!bl.empty()) {
        expectSame(bl, box(detector.detect(f.left)), "left band " + std::to_string(i));
        expectSame(br, box(detector.detect(f.right)), "right band " + std::to_string(i));
        lr.insert(lr.end(), bl.begin(), bl.end());
        rr.insert(rr.end(), br.begin(), br.end());
      }
    }
    bool box_seen = false;
    for (const auto& r : lr) box_seen = box_seen || r.class_index == 1;
    if (!plan.full && !box_seen) {
      ++windowed;
      // The ball's regions are the full scan's; the box (when there) is not seen.
      std::vector<perception::Region> fl = detector.detect(f.left), fr = detector.detect(f.right);
      const auto ball = [](std::vector<perception::Region> v) {
        v.erase(
            std::remove_if(v.begin(), v.end(), [](const auto& r) { return r.class_index != 0; }),
            v.end());
        return v;
      };
      expectSame(lr, ball(fl), "left frame " + std::to_string(i));
      expectSame(rr, ball(fr), "right frame " + std::to_string(i));
    }
    const auto objects = perception::associate(lr, rr, lv, rv, {});
    tracker.update(
        t, perception::trackMeasurements(objects, lr, rr, lv, rv, names, 1.3, tracker.tracks(), t));
    if (box_seen) {
      found_at = i;
      if (mode == NewObjects::kBands) {
        EXPECT_FALSE(plan.full) << plan.reason;
        expectSame(lr, detector.detect(f.left), "left frame " + std::to_string(i));
        expectSame(rr, detector.detect(f.right), "right frame " + std::to_string(i));
      } else if (mode == NewObjects::kBandAfter) {
        EXPECT_FALSE(plan.full) << plan.reason;
      } else {
        EXPECT_TRUE(plan.full) << "found in a window";
      }
    }
  }
  EXPECT_GE(windowed, 5);
  ASSERT_GE(found_at, appear);
  EXPECT_LT(found_at, appear + wp.full_scan_every);
}

TEST(Windows, ANewObjectAwayFromTheWindowsIsFoundByTheNextFullScan) {
  findsANewObject(NewObjects::kWholeFrames);
}

TEST(Windows, ANewObjectAwayFromTheWindowsIsFoundExactlyInItsBand) {
  findsANewObject(NewObjects::kBands);
}

TEST(Windows, ABandSearchedAfterTheWindowsFindsTheNewObjectAsExactly) {
  findsANewObject(NewObjects::kBandAfter);
}

// A track whose radius is too small for its object: the window cuts the ball; grown once it
// holds it (windowed, the full scan's region), or still cuts it and the frame is scanned whole.
TEST(Windows, AWindowThatCutsItsObjectGrowsOnceThenGivesUpToAFullScan) {
  const StereoRig rig = StereoRig::makeDefault();
  const perception::Detector detector(defaultClasses());
  sim::Scene scene;
  const Eigen::Vector3d ball(0.0, 0.0, 2.5);
  scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, ball, kRed)};
  const PtzPose pose{0, 0, 1};
  const sim::SimFrame f = simulator(rig, scene, pose)->capture();
  const CameraView lv = rig.view(Side::kLeft, pose), rv = rig.view(Side::kRight, pose);
  const auto full_l = detector.detect(f.left), full_r = detector.detect(f.right);
  ASSERT_EQ(full_l.size(), 1u);
  ASSERT_EQ(full_r.size(), 1u);
  perception::WindowParams wp;
  wp.margin_px = 4;
  wp.sigma_scale = 0;
  // About 20 px of ball radius: 0.07 m gives a window of about 18 px each side (grown: 36),
  // 0.02 m about 8 px (grown: 16, still inside the ball).
  for (const auto& [radius_m, windowed] : {std::pair<double, bool>{0.07, true}, {0.02, false}}) {
    perception::WindowScanner s(wp, f.left.size(), detector.exactMarginPx());
    perception::ScanPlan plan = s.plan({confirmedAt(ball, radius_m, 0)}, 0, lv, rv);
    ASSERT_FALSE(plan.full) << plan.reason;
    std::vector<perception::Region> l, r;
    std::string why;
    ASSERT_TRUE(s.detect(detector, &plan, fromMat(f.left), fromMat(f.right), &l, &r, &why)) << why;
    EXPECT_EQ(!plan.full, windowed) << radius_m;
    EXPECT_EQ(s.counts().at("windows_grown"), windowed ? 2 : 1) << radius_m;
    EXPECT_EQ(s.counts().at("windows_cut_to_full_scan"), windowed ? 0 : 1) << radius_m;
    EXPECT_EQ(s.counts().at("full_scans_cut"), windowed ? 0 : 1) << radius_m;
    expectSame(l, full_l, "left, radius " + std::to_string(radius_m));
    expectSame(r, full_r, "right, radius " + std::to_string(radius_m));
  }
}

// At 1080p, JPEG as ptz-detect reads it (bands found on their reduced rows, decoded from the
// rows' own restart segments): a new box taller than a band appears beside the tracked ball. It
// is found within a cycle of bands, in a windowed frame, exactly as a full-resolution full scan
// of the same decoded image finds it, though every band cuts it (its window runs on to the
// image's edge); the ball stays in its window all along.
TEST(Windows, At1080pANewObjectTallerThanABandIsFoundExactly) {
  const StereoRig rig = StereoRig::makeDefault().atSize(1920, 1080);
  const cv::Size size(1920, 1080);
  const perception::Detector detector(defaultClasses());
  const std::vector<std::string> names = {"red_ball", "green_box", "blue_ball"};
  const PtzPose pose{0, 0, 1};
  sim::Scene before, after;
  before.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, {0.3, 0.05, 2.5}, kRed)};
  after.objects = before.objects;
  sim::SceneObject box =
      object("green_box", sim::SceneObject::Shape::kBox, {-0.6, -0.1, 2.2}, kGreen);
  box.half_extents_m = {0.25, 0.25, 0.25};
  after.objects.push_back(box);
  auto sim_before = simulator(rig, before, pose), sim_after = simulator(rig, after, pose);
  perception::WindowParams wp;  // the defaults: 5 bands reaching 5 % into their neighbours
  perception::WindowScanner scanner(wp, size, detector.exactMarginPx());
  perception::Tracker tracker;
  const CameraView lv = rig.view(Side::kLeft, pose), rv = rig.view(Side::kRight, pose);
  const int appear = 12;
  int found_at = -1;
  int64_t full_before = -1;  // whole scans before the box appears (the ball's track not yet sure)
  for (int i = 0; i < 30 && found_at < 0; ++i) {
    const double t = 0.1 + i / 30.0;
    if (i == appear) full_before = scanner.counts().at("frames_scanned_full");
    sim::Simulator& s = i < appear ? *sim_before : *sim_after;
    s.advanceTo(t);
    const sim::SimFrame f = s.capture();
    const std::vector<uint8_t> lj =
        ptz::encodeImage(f.left, ptzstereo::image_t::ENCODING_JPEG, 90).data;
    const std::vector<uint8_t> rj =
        ptz::encodeImage(f.right, ptzstereo::image_t::ENCODING_JPEG, 90).data;
    perception::ScanPlan plan = scanner.plan(tracker.tracks(), t, lv, rv);
    std::vector<perception::Region> lr, rr;
    std::string why;
    ASSERT_TRUE(scanner.detect(detector, &plan, ptz::test::jpegPixels(lj, size),
                               ptz::test::jpegPixels(rj, size), &lr, &rr, &why))
        << why;
    const auto objects = perception::associate(lr, rr, lv, rv, {});
    tracker.update(
        t, perception::trackMeasurements(objects, lr, rr, lv, rv, names, 1.3, tracker.tracks(), t));
    bool box_seen = false;
    for (const auto& r : lr) box_seen = box_seen || r.class_index == 1;
    if (!box_seen) continue;
    found_at = i;
    EXPECT_FALSE(plan.full) << plan.reason;
    EXPECT_FALSE(plan.band.empty());
    EXPECT_GT(lr.back().bbox.height, plan.band.height) << "the box is not taller than a band";
    const std::string what = "frame " + std::to_string(i);
    expectSame(lr, detector.detect(cv::imdecode(lj, cv::IMREAD_COLOR)), "left " + what);
    expectSame(rr, detector.detect(cv::imdecode(rj, cv::IMREAD_COLOR)), "right " + what);
  }
  ASSERT_GE(found_at, appear);
  EXPECT_LT(found_at, appear + wp.full_scan_every);
  EXPECT_EQ(scanner.counts().at("frames_scanned_full"), full_before);  // none since
  EXPECT_LT(full_before, appear);
  EXPECT_GT(scanner.counts().at("bands_scanned"), 0);
}

// Both cameras' halves run at once on two threads (the first waits for the second, which a run in
// turn would never let happen), the second on the same thread call after call; either's exception
// reaches the caller; a call from inside runs both in turn.
TEST(Windows, BothCamerasRunAtOnceOnTwoThreads) {
  std::mutex m;
  std::condition_variable cv;
  std::thread::id ids[2], lane;
  for (int call = 0; call < 3; ++call) {
    bool second_started = false, met = false;
    ptz::perception::forBothCameras([&](int side) {
      std::unique_lock<std::mutex> lock(m);
      ids[side] = std::this_thread::get_id();
      if (side == 1) {
        second_started = true;
        cv.notify_all();
      } else {
        met = cv.wait_for(lock, std::chrono::seconds(30), [&] { return second_started; });
      }
    });
    EXPECT_TRUE(met);
    EXPECT_EQ(ids[0], std::this_thread::get_id());
    EXPECT_NE(ids[1], ids[0]);
    if (call > 0) {
      EXPECT_EQ(ids[1], lane);
    }
    lane = ids[1];
  }
  for (int thrower = 0; thrower < 2; ++thrower) {
    EXPECT_THROW(ptz::perception::forBothCameras([&](int side) {
                   if (side == thrower) throw std::runtime_error("side");
                 }),
                 std::runtime_error);
  }
  std::vector<int> order;
  ptz::perception::forBothCameras([&](int side) {
    if (side != 0) return;
    ptz::perception::forBothCameras([&](int inner) { order.push_back(inner); });
  });
  EXPECT_EQ(order, (std::vector<int>{0, 1}));
}
