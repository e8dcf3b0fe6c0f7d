// Fiducial markers on frames rendered by the simulator (JPEG as ptz-sim sends them, with its
// pixel noise): the tags' corners against their true projections, by libapriltag and by OpenCV's
// ArUco on the same images, and the pose from both views against the truth at 1-5 m (and 10 m
// zoomed), single tags and a box carrying a tag on each side.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>

#include "common/config.hpp"
#include "common/markers.hpp"
#include "perception/markers/marker_detector.hpp"
#include "perception/markers/marker_params.hpp"
#include "perception/markers/marker_pose.hpp"
#include "perception/markers/marker_scan.hpp"
#include "sim/simulator.hpp"
#include "support/render_aimed.hpp"

using ptz::CameraView;
using ptz::PtzPose;
using ptz::Side;
using ptz::StereoRig;
namespace perception = ptz::perception;
namespace sim = ptz::sim;

namespace {

// A white box of half extent half_m at centre, turned by yaw then pitch (degrees), with the tags.
sim::SceneObject taggedBox(const Eigen::Vector3d& centre, double half_m, double yaw_deg,
                           double pitch_deg, const std::vector<sim::SceneTag>& tags) {
  sim::SceneObject box;
  box.name = "tool";
  box.class_name = "tool";
  box.shape = sim::SceneObject::Shape::kBox;
  box.half_extents_m = Eigen::Vector3d::Constant(half_m);
  box.yaw_rad = yaw_deg * M_PI / 180;
  box.pitch_rad = pitch_deg * M_PI / 180;
  box.color_bgr = {235, 235, 235};
  box.trajectory.centre_m = centre;
  box.tags = tags;
  return box;
}

sim::SceneTag tag(const std::string& family, int id, double size_m, const Eigen::Vector3d& centre,
                  double yaw_deg, double pitch_deg = 0) {
  sim::SceneTag t;
  t.family = family;
  t.id = id;
  t.size_m = size_m;
  t.centre_m = centre;
  t.rotation_object_tag = ptz::tagRotation(yaw_deg, pitch_deg);
  std::string why;
  EXPECT_TRUE(ptz::markerCells(family, id, &t.cells, &why)) << why;
  return t;
}

using Frame = ptz::test::AimedFrame;

// The scene of one object (the backdrop behind the farthest tag) with both cameras aimed at `aim`.
Frame render(const sim::SceneObject& object, const Eigen::Vector3d& aim, double zoom) {
  sim::Scene scene;
  scene.backdrop_distance_m = 30;
  scene.objects = {object};
  return ptz::test::renderAimed(StereoRig::makeDefault(), scene, aim, zoom);
}

perception::MarkerClass singleTags(const std::string& detector, const std::string& family,
                                   double size_m) {
  perception::MarkerClass c;
  c.name = "tag";
  c.detector = detector;
  c.family = family;
  c.size_m = size_m;
  c.any_id = true;
  return c;
}

// The true head-frame corners of a tag of the object (the detectors' order).
std::vector<Eigen::Vector3d> trueCorners(const sim::SceneObject& o, const sim::SceneTag& t) {
  const Eigen::Matrix3d R = o.rotationHeadObject(0.05);
  const Eigen::Vector3d c = o.trajectory.position(0.05);
  const double h = t.size_m / 2;
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector3d& k : {Eigen::Vector3d(-h, -h, 0), Eigen::Vector3d(h, -h, 0),
                                   Eigen::Vector3d(h, h, 0), Eigen::Vector3d(-h, h, 0)}) {
    out.push_back(c + R * (t.centre_m + t.rotation_object_tag * k));
  }
  return out;
}

// A tag of 0.14 m on each side of a cube of half extent h (ids 0-3), and their class (a bundle).
std::vector<sim::SceneTag> cubeTags(double h) {
  const double s = 0.14;
  return {tag("apriltag_36h11", 0, s, {0, 0, -h}, 0), tag("apriltag_36h11", 1, s, {h, 0, 0}, -90),
          tag("apriltag_36h11", 2, s, {0, 0, h}, 180), tag("apriltag_36h11", 3, s, {-h, 0, 0}, 90)};
}

perception::MarkerClass bundleOf(const std::vector<sim::SceneTag>& tags) {
  perception::MarkerClass mc;
  mc.name = "tool";
  mc.size_m = tags.at(0).size_m;
  for (const auto& t : tags) mc.bundle.push_back({t.id, t.centre_m, t.rotation_object_tag});
  return mc;
}

double angleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180 / M_PI;
}

}  // namespace

TEST(MarkerFamilies, CellsHaveTheBlackBorderAndTheCode) {
  cv::Mat cells;
  std::string why;
  ASSERT_TRUE(ptz::markerCells("apriltag_36h11", 0, &cells, &why)) << why;
  ASSERT_EQ(cells.rows, 8);  // 6 x 6 bits and the border
  for (int k = 0; k < 8; ++k) {
    EXPECT_EQ(cells.at<uchar>(0, k), 0);
    EXPECT_EQ(cells.at<uchar>(7, k), 0);
    EXPECT_EQ(cells.at<uchar>(k, 0), 0);
    EXPECT_EQ(cells.at<uchar>(k, 7), 0);
  }
  EXPECT_EQ(ptz::markerFamilyCount("apriltag_36h11"), 587);
  EXPECT_EQ(ptz::markerFamilyCount("aruco_4x4_50"), 50);
  EXPECT_FALSE(ptz::markerCells("apriltag_36h11", 587, &cells, &why));
  EXPECT_NE(why.find("587"), std::string::npos);
  EXPECT_FALSE(ptz::markerCells("qr", 0, &cells, &why));
  EXPECT_NE(why.find("qr"), std::string::npos);
}

// Each detector reads the rendered tag's id, and its corners where the tag's truth projects, in the
// order top-left, top-right, bottom-right, bottom-left, whatever the tag's turn in the image.
TEST(MarkerDetector, CornersAtTheTruthByBothDetectors) {
  for (const std::string detector : {"apriltag", "aruco"}) {
    for (double roll_deg : {0.0, 35.0, 120.0}) {
      const sim::SceneTag t = tag("apriltag_36h11", 7, 0.16, {0, 0, -0.1}, 0);
      sim::SceneObject box = taggedBox({0.1, 0.05, 2.0}, 0.1, 20, -15, {t});
      box.roll_rad = roll_deg * M_PI / 180;
      const Frame f = render(box, {0.1, 0.05, 2.0}, 1);
      perception::MarkerDetector d({singleTags(detector, "apriltag_36h11", 0.16)});
      const auto seen = d.detect(f.left, {0, 0});
      ASSERT_EQ(seen.size(), 1u) << detector << " roll " << roll_deg;
      EXPECT_EQ(seen[0].id, 7);
      const auto truth = trueCorners(box, t);
      double sum2 = 0;
      cv::Point2d mean(0, 0);
      for (size_t k = 0; k < 4; ++k) {
        const Eigen::Vector2d p = f.left_view.project(truth[k]);
        const cv::Point2d e = seen[0].corners_px[k] - cv::Point2d(p.x(), p.y());
        mean += e * 0.25;
        sum2 += e.dot(e);
        EXPECT_LT(cv::norm(e), 1.0) << detector << " roll " << roll_deg << " corner " << k;
      }
      const double rms = std::sqrt(sum2 / 4);
      std::printf("%s roll %.0f deg: corner RMS %.3f px, mean (%.2f, %.2f)\n", detector.c_str(),
                  roll_deg, rms, mean.x, mean.y);
      EXPECT_LT(rms, 0.35) << detector;
    }
  }
}

// A part of an image: the corners in full-image coordinates; an id no class takes is counted.
TEST(MarkerDetector, PartOffsetAndUnclaimedIds) {
  const sim::SceneTag t = tag("apriltag_36h11", 3, 0.16, {0, 0, -0.1}, 0);
  const sim::SceneObject box = taggedBox({0, 0, 2.0}, 0.1, 0, 0, {t});
  const Frame f = render(box, {0, 0, 2.0}, 1);
  perception::MarkerClass c = singleTags("apriltag", "apriltag_36h11", 0.16);
  perception::MarkerDetector whole({c});
  const auto all = whole.detect(f.left, {0, 0});
  ASSERT_EQ(all.size(), 1u);
  // Even offsets: libapriltag finds the quads on the image halved, whose grid then stays the same.
  const cv::Rect seen = all[0].bbox();
  const cv::Rect part((seen.x - 20) & ~1, (seen.y - 20) & ~1, seen.width + 40, seen.height + 40);
  const auto in_part = whole.detect(f.left(part), part.tl());
  ASSERT_EQ(in_part.size(), 1u);
  for (size_t k = 0; k < 4; ++k)
    EXPECT_LT(cv::norm(in_part[0].corners_px[k] - all[0].corners_px[k]), 0.2);
  c.any_id = false;
  c.ids = {4, 5};
  perception::MarkerDetector other({c});
  int unclaimed = 0;
  EXPECT_TRUE(other.detect(f.left, {0, 0}, &unclaimed).empty());
  EXPECT_EQ(unclaimed, 1);
}

// The pose from both views, zoomed as ptz-control zooms (the tag about as large in the image at
// every range): position within 0.3 % of the range at 1-10 m; orientation within 1 degree where
// the tag is turned from the cameras by 20 degrees or more, and everywhere within 4 sigma of the
// pose's own covariance (a tag squarely facing the cameras tells its tilt only by perspective and
// disparity across its width, which shrink with range: what it reaches is printed).
TEST(MarkerPose, SingleTagAgainstTruth) {
  struct Case {
    double z_m, yaw_deg, pitch_deg;
  };
  const Case cases[] = {{1, 0, 0},     {1, 40, -20}, {2, -30, 25}, {2, 5, 0}, {3, 50, 10},
                        {4, -20, -30}, {5, 30, 20},  {5, -45, 0},  {5, 0, 5}, {10, 25, 15}};
  for (const std::string detector : {"apriltag", "aruco"}) {
    for (const Case& c : cases) {
      // Two cells of white around the tag (a printed tag's quiet zone).
      const sim::SceneTag t = tag("apriltag_36h11", 11, 0.16, {0, 0, -0.12}, 0);
      const Eigen::Vector3d centre(0.15, -0.1, c.z_m);
      const sim::SceneObject box = taggedBox(centre, 0.12, c.yaw_deg, c.pitch_deg, {t});
      const double zoom = std::max(1.0, c.z_m / 1.5);
      const Frame f = render(box, centre, zoom);
      perception::MarkerClass mc = singleTags(detector, "apriltag_36h11", 0.16);
      perception::MarkerDetector dl({mc}), dr({mc});
      std::vector<std::string> failed;
      const auto objects = perception::markerObjects({mc}, dl.detect(f.left, {0, 0}, nullptr, 1),
                                                     dr.detect(f.right, {0, 0}, nullptr, 1),
                                                     f.left_view, f.right_view, {}, &failed);
      ASSERT_EQ(objects.size(), 1u)
          << detector << " at " << c.z_m << " m" << (failed.empty() ? "" : ": " + failed[0]);
      const perception::MarkerObject& o = objects[0];
      EXPECT_EQ(o.name, "tag#11");
      const Eigen::Matrix3d R_true = box.rotationHeadObject(0.05) * t.rotation_object_tag;
      const Eigen::Vector3d p_true = centre + box.rotationHeadObject(0.05) * t.centre_m;
      const double angle_deg = angleDeg(o.pose.rotation_head_object, R_true);
      const double err_pct = 100 * (o.pose.position_head_m - p_true).norm() / p_true.norm();
      const double sigma_deg =
          std::sqrt(o.pose.covariance.topLeftCorner<3, 3>().trace()) * 180 / M_PI;
      // How far the tag turns from facing the left camera.
      const double turned_deg =
          std::acos(
              std::abs(R_true.col(2).dot((p_true - f.left_view.position_head_m).normalized()))) *
          180 / M_PI;
      std::printf(
          "%-8s %4.1f m zoom %.1f, turned %4.1f deg: %.3f deg (sigma %.3f), %.3f %% "
          "(rms %.2f px)\n",
          detector.c_str(), c.z_m, zoom, turned_deg, angle_deg, sigma_deg, err_pct, o.pose.rms_px);
      if (turned_deg >= 20) {
        EXPECT_LT(angle_deg, 1.0) << detector << " " << c.z_m << " m";
      }
      EXPECT_LT(angle_deg, 4 * sigma_deg) << detector << " " << c.z_m << " m";
      EXPECT_LT(err_pct, 0.3) << detector << " " << c.z_m << " m";
    }
  }
}

// A box with a tag on each side, as one object (a bundle): its own frame's pose from whichever
// tags are seen, through a whole turn: within 1 degree where two faces are seen, else within 4
// sigma of its covariance (one face squarely seen, as a single tag).
TEST(MarkerPose, BundleThroughAWholeTurn) {
  const double h = 0.1;
  const std::vector<sim::SceneTag> tags = cubeTags(h);
  const perception::MarkerClass mc = bundleOf(tags);
  const Eigen::Vector3d centre(-0.1, 0.1, 2.0);
  for (double yaw_deg = 0; yaw_deg < 360; yaw_deg += 30) {
    const sim::SceneObject box = taggedBox(centre, h, yaw_deg, 10, tags);
    const Frame f = render(box, centre, 1);
    perception::MarkerDetector dl({mc}), dr({mc});
    std::vector<std::string> failed;
    const auto objects = perception::markerObjects({mc}, dl.detect(f.left, {0, 0}, nullptr, 1),
                                                   dr.detect(f.right, {0, 0}, nullptr, 1),
                                                   f.left_view, f.right_view, {}, &failed);
    ASSERT_EQ(objects.size(), 1u) << "yaw " << yaw_deg;
    const perception::MarkerObject& o = objects[0];
    const double angle_deg = angleDeg(o.pose.rotation_head_object, box.rotationHeadObject(0.05));
    const double err_pct = 100 * (o.pose.position_head_m - centre).norm() / centre.norm();
    const double sigma_deg =
        std::sqrt(o.pose.covariance.topLeftCorner<3, 3>().trace()) * 180 / M_PI;
    std::printf("bundle yaw %3.0f: %zu+%zu tags, %.3f deg (sigma %.3f), %.3f %%\n", yaw_deg,
                o.sightings[0].size(), o.sightings[1].size(), angle_deg, sigma_deg, err_pct);
    // Two faces seen: their tags at an angle fix every axis.
    if (o.sightings[0].size() + o.sightings[1].size() >= 3) {
      EXPECT_LT(angle_deg, 1.0) << "yaw " << yaw_deg;
    }
    EXPECT_LT(angle_deg, 4 * sigma_deg) << "yaw " << yaw_deg;
    EXPECT_LT(err_pct, 0.3) << "yaw " << yaw_deg;
  }
}

// A tracked tagged object is looked for in a window around each of its tags that faces the camera
// (from its track's orientation), far smaller than the object's window, each holding its tag's true
// corners 2 px clear; there the object's tags are found as in the whole images. A track lost a
// while (its window mostly uncertainty) is looked for with the band, not in the frame's windows.
TEST(MarkerScanner, ATrackedObjectIsLookedForAroundTheTagsThatFaceTheCamera) {
  const double h = 0.1;
  const std::vector<sim::SceneTag> tags = cubeTags(h);
  const perception::MarkerClass mc = bundleOf(tags);
  const Eigen::Vector3d centre(-0.1, 0.1, 2.0);
  const sim::SceneObject box = taggedBox(centre, h, 45, 10, tags);
  const Frame f = render(box, centre, 1);
  const double t_s = 0.05;
  perception::Track track;
  track.class_name = "tool";
  track.state = perception::TrackState::kConfirmed;
  track.x.head<3>() = centre;
  track.P = Eigen::Matrix<double, 9, 9>::Identity() * 1e-6;
  track.radius_m = mc.radiusM();
  track.t_s = t_s;
  track.rotation.ok = true;
  track.rotation.rotation = Eigen::Quaterniond(box.rotationHeadObject(t_s));
  track.rotation.covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e-6;
  track.rotation.t_s = t_s;
  const cv::Size image(f.left.cols, f.left.rows);
  perception::MarkerScanParams params;
  params.window_max_object_areas = 4;  // this near, 9 would be half the image
  perception::MarkerScanner scanner({mc}, params, image);
  const perception::WindowParams wp;
  // The tags that face each camera, by the truth: two at 45 degrees of yaw.
  for (const CameraView* view : {&f.left_view, &f.right_view}) {
    std::vector<const sim::SceneTag*> facing;
    for (const sim::SceneTag& t : tags) {
      const std::vector<Eigen::Vector3d> c = trueCorners(box, t);
      Eigen::Vector3d cam[4];
      for (int i = 0; i < 4; ++i) cam[i] = view->toCamera(c[static_cast<size_t>(i)]);
      const Eigen::Vector3d n = (cam[1] - cam[0]).cross(cam[3] - cam[0]).normalized();
      if (n.dot(((cam[0] + cam[2]) / 2).normalized()) > 0.1) facing.push_back(&t);
    }
    ASSERT_EQ(facing.size(), 2u);
    std::vector<cv::Rect> windows;
    ASSERT_TRUE(scanner.tagWindows(*view, track, mc, t_s, wp, &windows));
    ASSERT_EQ(windows.size(), facing.size());
    cv::Rect object;
    ASSERT_TRUE(perception::trackWindow(*view, track, t_s, wp, &object));
    for (size_t k = 0; k < windows.size(); ++k) {
      EXPECT_LT(windows[k].area(), object.area() / 3);
      const cv::Rect inner(windows[k].x + 2, windows[k].y + 2, windows[k].width - 4,
                           windows[k].height - 4);
      for (const Eigen::Vector3d& c : trueCorners(box, *facing[k])) {
        const Eigen::Vector2d px = view->project(c);
        EXPECT_TRUE(inner.contains(cv::Point(static_cast<int>(px.x()), static_cast<int>(px.y()))))
            << "tag " << facing[k]->id << " corner " << px.transpose();
      }
    }
  }
  const perception::CropPixels crops[2] = {[&](const cv::Rect& r, cv::Mat* out, std::string*) {
                                             *out = f.left(r);
                                             return true;
                                           },
                                           [&](const cv::Rect& r, cv::Mat* out, std::string*) {
                                             *out = f.right(r);
                                             return true;
                                           }};
  perception::MarkerScan found;
  std::string why;
  ASSERT_TRUE(scanner.scan({track}, t_s, f.left_view, f.right_view, wp, crops, &found, &why,
                           perception::ScanParts::kWindows))
      << why;
  ASSERT_EQ(found.objects.size(), 1u);
  perception::MarkerDetector whole({mc});
  EXPECT_EQ(found.sightings[0].size(), whole.detect(f.left, {0, 0}, nullptr, 1).size());
  EXPECT_EQ(found.sightings[1].size(), whole.detect(f.right, {0, 0}, nullptr, 1).size());
  EXPECT_EQ(found.sightings[0].size(), 2u);
  EXPECT_LT(angleDeg(found.objects[0].pose.rotation_head_object, box.rotationHeadObject(t_s)), 1.0);
  EXPECT_EQ(scanner.counts().at("marker_tag_windows"), 2);
  // Lost: coasting with 8 cm of uncertainty, a window over 4 times the object's (not yet half the
  // image). Not in the frame's windows; with the band, in its own window. A track that does not
  // coast is never lost (a new one's window is wide, its speed not known yet).
  track.state = perception::TrackState::kCoasting;
  ASSERT_FALSE(scanner.lost(f.left_view, track, t_s, wp));
  track.P = Eigen::Matrix<double, 9, 9>::Identity() * 0.08 * 0.08;
  ASSERT_TRUE(scanner.lost(f.left_view, track, t_s, wp));
  track.state = perception::TrackState::kTentative;
  EXPECT_FALSE(scanner.lost(f.left_view, track, t_s, wp));
  track.state = perception::TrackState::kCoasting;
  cv::Rect grown;
  ASSERT_TRUE(perception::trackWindow(f.left_view, track, t_s, wp, &grown));
  ASSERT_LT(grown.area(), wp.max_cover_fraction * image.area());
  ASSERT_TRUE(scanner.scan({track}, t_s, f.left_view, f.right_view, wp, crops, &found, &why,
                           perception::ScanParts::kWindows));
  EXPECT_TRUE(found.objects.empty());
  ASSERT_TRUE(scanner.scan({track}, t_s, f.left_view, f.right_view, wp, crops, &found, &why,
                           perception::ScanParts::kNew));
  EXPECT_EQ(found.objects.size(), 1u);
  EXPECT_EQ(scanner.counts().at("marker_windows_lost"), 2);  // both views, the band's scan
}

// Corners that do not belong together (the right view's tag elsewhere) fail the reprojection
// test; fewer than three corners in both views fix nothing.
TEST(MarkerPose, RefusesWhatDoesNotFit) {
  const StereoRig rig = StereoRig::makeDefault();
  const CameraView lv = rig.view(Side::kLeft, {}), rv = rig.view(Side::kRight, {});
  perception::MarkerClass mc;
  mc.size_m = 0.2;
  std::vector<perception::MarkerCorner> corners;
  const auto model = mc.corners(0);
  const Eigen::Vector3d at(0, 0, 3);
  for (size_t k = 0; k < 4; ++k) {
    perception::MarkerCorner c;
    c.model_m = model[k];
    c.seen[0] = c.seen[1] = true;
    c.pixel[0] = lv.project(at + model[k]);
    c.pixel[1] = rv.project(at + model[k]);
    corners.push_back(c);
  }
  perception::MarkerPose pose;
  std::string why;
  ASSERT_TRUE(perception::estimateMarkerPose(corners, lv, rv, {}, &pose, &why)) << why;
  EXPECT_LT((pose.position_head_m - at).norm(), 1e-6);
  EXPECT_LT(angleDeg(pose.rotation_head_object, Eigen::Matrix3d::Identity()), 1e-4);
  auto skewed = corners;
  skewed[2].pixel[1] += Eigen::Vector2d(6, -4);  // one corner of the right view moved
  EXPECT_FALSE(perception::estimateMarkerPose(skewed, lv, rv, {}, &pose, &why));
  EXPECT_EQ(why.rfind("reprojection", 0), 0u) << why;
  auto few = corners;
  few[0].seen[1] = few[1].seen[1] = false;
  EXPECT_FALSE(perception::estimateMarkerPose(few, lv, rv, {}, &pose, &why));
  EXPECT_EQ(why.rfind("few_corners", 0), 0u) << why;
}

TEST(MarkerParams, ConfigErrorsNameTheField) {
  auto parse = [](const std::string& yaml) {
    cv::FileStorage fs(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    return perception::markerClassesFromConfig(fs["markers"], "config file 'x.yaml'");
  };
  auto error = [&](const std::string& yaml) {
    try {
      parse(yaml);
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const auto ok = parse(
      "%YAML:1.0\nmarkers:\n  - name: tool\n    size_m: 0.1\n    tags:\n      - {id: 0, centre_m: "
      "[0, "
      "0, -0.1]}\n      - {id: 1, centre_m: [0.1, 0, 0], yaw_deg: -90}\n  - {name: tag, detector: "
      "aruco, family: aruco_4x4_50, size_m: 0.05, ids: any}\n");
  ASSERT_EQ(ok.size(), 2u);
  EXPECT_TRUE(ok[0].isBundle());
  EXPECT_EQ(ok[0].objectName(1), "tool");
  EXPECT_EQ(ok[0].objectName(2), "");
  EXPECT_EQ(ok[1].objectName(9), "tag#9");
  EXPECT_NE(error("%YAML:1.0\nmarkers:\n  - {name: t, family: qr, size_m: 0.1, ids: [1]}\n")
                .find("markers[0].family: unknown family 'qr'"),
            std::string::npos);
  EXPECT_NE(error("%YAML:1.0\nmarkers:\n  - {name: t, size_m: 0.1, ids: [587]}\n").find("ids"),
            std::string::npos);
  EXPECT_NE(error("%YAML:1.0\nmarkers:\n  - {name: t, size_m: 0.1, ids: [1], tags: [{id: 1, "
                  "centre_m: [0, 0, 0]}]}\n")
                .find("either ids or tags"),
            std::string::npos);
  EXPECT_NE(error("%YAML:1.0\nmarkers:\n  - {name: a, size_m: 0.1, ids: [1, 2]}\n  - {name: b, "
                  "size_m: 0.1, ids: any}\n")
                .find("markers[1]: tag 1 of apriltag_36h11 is also class 'a''s"),
            std::string::npos);
  EXPECT_NE(
      error("%YAML:1.0\nmarkers:\n  - {name: t, detector: apriltag, family: aruco_4x4_50, size_m: "
            "0.1, ids: any}\n")
          .find("detector apriltag reads"),
      std::string::npos);
  EXPECT_NE(error("%YAML:1.0\nmarkers:\n  - {name: 'a#b', size_m: 0.1, ids: any}\n").find("'#'"),
            std::string::npos);
}

// Parts of an image a few pixels high or wide (a tagged track's window cut by the image's edge):
// libapriltag 3.3 divides by zero or reads outside them (fuzz_markers' finds); the detector finds
// nothing in them, at every decimation.
TEST(MarkerDetector, SliversOfAnImageFindNothing) {
  perception::MarkerDetector april({singleTags("apriltag", "apriltag_36h11", 0.1)});
  perception::MarkerDetector aruco({singleTags("aruco", "aruco_4x4_50", 0.1)});
  for (const cv::Size size : {cv::Size(5, 1), cv::Size(1, 5), cv::Size(64, 2), cv::Size(2, 64),
                              cv::Size(3, 3), cv::Size(7, 6)}) {
    cv::Mat grey(size, CV_8UC1);
    cv::randu(grey, 0, 255);
    for (double decimate : {1.0, 1.5, 2.0, 4.0}) {
      EXPECT_TRUE(april.detect(grey, {10, 10}, nullptr, decimate).empty()) << size;
    }
    EXPECT_TRUE(aruco.detect(grey, {10, 10}).empty()) << size;
  }
}
