// Tracks moved by one view (Tracker::updateFromViews): an object hidden in the right image goes on
// being measured by the left one, along the image, while its depth is recent; the pairing must
// be unique, the apparent size the track's, and the depth not too old.
#include <gtest/gtest.h>

#include <cmath>

#include "common/rig.hpp"
#include "perception/tracking/tracker.hpp"

namespace ptz::perception {
namespace {

constexpr double kFrameS = 1.0 / 30;
constexpr double kRadiusM = 0.1;

struct Scene {
  StereoRig rig = StereoRig::makeDefault();
  CameraView left = rig.view(Side::kLeft, {0, 0, 1});
  CameraView right = rig.view(Side::kRight, {0, 0, 1});
};

// A ball at 3 m, crossing at 0.5 m/s and slowly coming nearer.
Eigen::Vector3d path(double t_s) {
  return {-0.5 + 0.5 * t_s, 0.1, 3.0 - 0.1 * t_s};
}

TrackMeasurement stereo(const Eigen::Vector3d& p) {
  TrackMeasurement m;
  m.class_name = "red_ball";
  m.position_m = p;
  m.covariance_m2 = Eigen::Matrix3d::Identity() * 1e-5;
  m.radius_m = kRadiusM;
  m.object_index = 0;
  return m;
}

ViewMeasurement seen(const CameraView& view, Side side, const Eigen::Vector3d& p,
                     double radius_m = kRadiusM) {
  ViewMeasurement m;
  m.class_name = "red_ball";
  m.side = side;
  m.pixel = view.project(p);
  m.sigma_px = 0.3;
  m.radius_px = view.intrinsics.fx * radius_m / (p - view.position_head_m).norm();
  m.region_index = 4;
  return m;
}

// One second of stereo measurements: a confirmed track with a good velocity.
Tracker tracked(double* t_s) {
  Tracker tracker;
  for (*t_s = 0; *t_s < 1.0; *t_s += kFrameS) tracker.update(*t_s, {stereo(path(*t_s))});
  return tracker;
}

TEST(ViewUpdate, AnObjectHiddenInOneViewIsMeasuredInTheOtherAlongTheImage) {
  const Scene s;
  double t = 0;
  Tracker with_view = tracked(&t), coasting = with_view;
  for (int frame = 0; frame < 12; ++frame, t += kFrameS) {  // 0.4 s hidden in the right view
    with_view.update(t, {});
    with_view.updateFromViews(t, {seen(s.left, Side::kLeft, path(t))}, s.left, s.right);
    coasting.update(t, {});
    const Track& v = with_view.tracks().at(0);
    EXPECT_EQ(v.state, TrackState::kConfirmed) << t;
    EXPECT_EQ(v.view_region_index, 4);
    EXPECT_EQ(v.view_side, Side::kLeft);
    EXPECT_EQ(v.object_index, -1);
    EXPECT_EQ(coasting.tracks().at(0).state, TrackState::kCoasting);
    // In the image that sees it, the track is on the object; in 3D within 1 cm (depth predicted).
    EXPECT_LT((s.left.project(v.position()) - s.left.project(path(t))).norm(), 0.3) << t;
    EXPECT_LT((v.position() - path(t)).norm(), 0.01) << t;
  }
  EXPECT_EQ(with_view.viewUpdates(), 12);
  EXPECT_EQ(coasting.viewUpdates(), 0);
}

TEST(ViewUpdate, TheSideMeasuredIsTheRightOneToo) {
  const Scene s;
  double t = 0;
  Tracker tracker = tracked(&t);
  tracker.update(t, {});
  tracker.updateFromViews(t, {seen(s.right, Side::kRight, path(t))}, s.left, s.right);
  EXPECT_EQ(tracker.tracks().at(0).view_side, Side::kRight);
  EXPECT_LT((s.right.project(tracker.tracks().at(0).position()) - s.right.project(path(t))).norm(),
            0.3);
}

TEST(ViewUpdate, NoUpdateWhereThePairingIsNotUniqueOrTheSizeOrDepthIsWrong) {
  const Scene s;
  double t = 0;
  {  // Two tracks at the region's place (one behind the other on the left camera's ray): neither.
    Tracker tracker;
    const Eigen::Vector3d c = s.left.position_head_m;
    const Eigen::Vector3d behind = c + (path(0) - c) * 1.2;
    for (t = 0; t < 1.0; t += kFrameS) {
      TrackMeasurement b = stereo(behind);
      b.object_index = 1;
      tracker.update(t, {stereo(path(0)), b});
    }
    ASSERT_EQ(tracker.tracks().size(), 2u);
    tracker.update(t, {});
    const double a = s.left.intrinsics.fx * kRadiusM;
    ViewMeasurement m = seen(s.left, Side::kLeft, path(0));
    // Between the two sizes, within both ratios.
    m.radius_px = a / (0.5 * ((path(0) - c).norm() + (behind - c).norm()));
    tracker.updateFromViews(t, {m}, s.left, s.right);
    EXPECT_EQ(tracker.viewUpdates(), 0);
  }
  {  // A look-alike lost for 0.6 s (its depth too old to move it) whose predicted disc overlaps
     // the region: the region may be it, so the target is not moved by it.
    Tracker tracker;
    const Eigen::Vector3d c = s.left.position_head_m;
    double end = 0;
    for (t = 0; t < 1.0; t += kFrameS) end = t;
    const Eigen::Vector3d other =
        c + (path(end + kFrameS) - c) * 1.15 + Eigen::Vector3d(0.02, 0, 0);
    for (t = 0; t < 1.0; t += kFrameS) {
      TrackMeasurement b = stereo(other);
      b.object_index = 1;
      std::vector<TrackMeasurement> both = {stereo(path(t))};
      if (t < 0.4 - 1e-9) both.push_back(b);  // the look-alike unseen from 0.4 s on
      tracker.update(t, both);
    }
    ASSERT_EQ(tracker.tracks().size(), 2u);
    tracker.update(t, {});
    tracker.updateFromViews(t, {seen(s.left, Side::kLeft, path(t))}, s.left, s.right);
    EXPECT_EQ(tracker.viewUpdates(), 0);
  }
  {  // A region twice the track's apparent size is another object.
    Tracker tracker = tracked(&t);
    tracker.update(t, {});
    tracker.updateFromViews(t, {seen(s.left, Side::kLeft, path(t), 2 * kRadiusM)}, s.left, s.right);
    EXPECT_EQ(tracker.viewUpdates(), 0);
  }
  {  // Two regions near one track: no evidence of which.
    Tracker tracker = tracked(&t);
    tracker.update(t, {});
    ViewMeasurement a = seen(s.left, Side::kLeft, path(t)), b = a;
    b.pixel.x() += 0.5;
    tracker.updateFromViews(t, {a, b}, s.left, s.right);
    EXPECT_EQ(tracker.viewUpdates(), 0);
  }
  {  // 0.6 s since the last 3D measurement: its depth has drifted, one view cannot fix it.
    Tracker tracker = tracked(&t);
    for (int frame = 0; frame < 18; ++frame, t += kFrameS) tracker.update(t, {});
    tracker.update(t, {});
    tracker.updateFromViews(t, {seen(s.left, Side::kLeft, path(t))}, s.left, s.right);
    EXPECT_EQ(tracker.viewUpdates(), 0);
    EXPECT_EQ(tracker.tracks().at(0).state, TrackState::kCoasting);
  }
}

}  // namespace
}  // namespace ptz::perception
