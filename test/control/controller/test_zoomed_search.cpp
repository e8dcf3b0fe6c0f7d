// The search's zoomed levels: their zooms, views that tile the wide field around the centre
// nearest first, and a search from home that brings a small far object (too small to find at the
// widest zoom) into both views at a zoom that resolves it, within 15 s, through the plant's lag.
#include <gtest/gtest.h>

#include <cmath>

#include "common/plant.hpp"
#include "control/controller/controller.hpp"
#include "control/controller/search.hpp"

namespace ptz::control {
namespace {

constexpr double kFrameS = 1.0 / 30;

TEST(ZoomedSearch, LevelsMultiplyByTheStepUpToTheTopZoom) {
  const StereoRig rig = StereoRig::makeDefault();  // 1x to 10x
  SearchParams p;
  EXPECT_EQ(searchZooms(p, rig.left), std::vector<double>({4.0}));
  p.zoom_step = 3;
  p.max_zoom = 10;
  EXPECT_EQ(searchZooms(p, rig.left), std::vector<double>({3.0, 9.0}));  // 10 is near 9
  p.zoom_step = 2;
  p.max_zoom = 20;  // beyond the lens: its 10x
  EXPECT_EQ(searchZooms(p, rig.left), std::vector<double>({2.0, 4.0, 8.0}));
  p.max_zoom = 1;  // the widest: no zoomed levels
  EXPECT_TRUE(searchZooms(p, rig.left).empty());
}

TEST(ZoomedSearch, ViewsTileTheWideFieldNearestTheCentreFirst) {
  const StereoRig rig = StereoRig::makeDefault();
  SearchParams p;
  const Eigen::Vector2d wide = widestFieldOfView(rig.left), fov = fieldOfView(rig.left, 4);
  EXPECT_NEAR(fov.x(), 2 * std::atan(320.0 / (4 * 500)), 1e-3);
  const Eigen::Vector2d centre(0.3, 0.1);
  const auto views = zoomedViews(p, fov, wide, centre);
  ASSERT_FALSE(views.empty());
  EXPECT_LT((views.front() - centre).norm(), fov.x() * (1 - p.overlap) / 2);
  for (size_t i = 1; i < views.size(); ++i) {
    EXPECT_LE((views[i - 1] - centre).norm(), (views[i] - centre).norm() + 1e-12);
  }
  // Every direction of the wide field around the centre is inside some zoomed view.
  for (double dx = -wide.x() / 2; dx <= wide.x() / 2 + 1e-9; dx += wide.x() / 40) {
    for (double dy = -wide.y() / 2; dy <= wide.y() / 2 + 1e-9; dy += wide.y() / 40) {
      bool inside = false;
      for (const auto& v : views) {
        inside |= std::abs(centre.x() + dx - v.x()) <= fov.x() / 2 + 1e-9 &&
                  std::abs(centre.y() + dy - v.y()) <= fov.y() / 2 + 1e-9;
      }
      EXPECT_TRUE(inside) << dx << " " << dy;
    }
  }
  // Clamped to the search region: none beyond its edges.
  p.pan_max_rad = 0.35;
  for (const auto& v : zoomedViews(p, fov, wide, centre)) EXPECT_LE(v.x(), 0.35);
}

// A search that began at an edge of the region (looking straight up, at the tilt limit) tiles the
// field shifted inside the region: as many views, none twice, all within it.
TEST(ZoomedSearch, AtTheRegionsEdgeTheFieldShiftsInsideWithoutRepeatingViews) {
  const StereoRig rig = StereoRig::makeDefault();
  SearchParams p;
  const Eigen::Vector2d wide = widestFieldOfView(rig.left), fov = fieldOfView(rig.left, 4);
  const auto inside = zoomedViews(p, fov, wide, {0.0, 0.0});
  const auto edge = zoomedViews(p, fov, wide, {0.0, p.tilt_max_rad});
  EXPECT_EQ(edge.size(), inside.size());
  for (size_t i = 0; i < edge.size(); ++i) {
    EXPECT_LE(edge[i].y(), p.tilt_max_rad + 1e-12);
    EXPECT_GE(edge[i].y(), p.tilt_min_rad - 1e-12);
    for (size_t k = 0; k < i; ++k) EXPECT_GT((edge[i] - edge[k]).norm(), 1e-6) << i << " " << k;
  }
}

// Whether both cameras at these poses image p at least margin_px inside their frames.
bool inBothViews(const StereoRig& rig, const std::array<PtzPose, 2>& poses,
                 const Eigen::Vector3d& p, double margin_px) {
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector2d px = rig.view(i == 0 ? Side::kLeft : Side::kRight, poses[i]).project(p);
    if (!px.allFinite() || px.x() < margin_px || px.y() < margin_px || px.x() > 639 - margin_px ||
        px.y() > 479 - margin_px) {
      return false;
    }
  }
  return true;
}

// From home with no target, the heads (the plant: first-order lag, rate limits) go through the
// wide sweep and then the zoomed views: a 10 cm ball 20 m away, 6 degrees off the home axis (4 px
// across at the widest zoom, below what a scan finds), is in both views at zoom 4 (16 px across)
// for at least 6 frames in a row (found and confirmed) within 15 s.
TEST(ZoomedSearch, ASmallFarObjectNearWhereTheSearchBeganIsSeenZoomedWithinFifteenSeconds) {
  const StereoRig rig = StereoRig::makeDefault();
  ControllerParams params;
  Controller c(rig, params);
  PtzPlant plant(defaultPlantParams(), PtzPose{0, 0, 1}, PtzPose{0, 0, 1});
  const Eigen::Vector3d ball(2.0, -0.5, 20.0);
  int run = 0;
  double seen_s = -1;
  std::array<PtzPose, 2> at{};
  for (int k = 0; k < 30 * 20 && seen_s < 0; ++k) {
    const double t = k * kFrameS;
    at = {plant.pose(Side::kLeft), plant.pose(Side::kRight)};
    const auto sp = c.update(t, std::nullopt, at[0], at[1]);
    int clamped = 0, rejected = 0;
    plant.command(t, sp[0], sp[1], &clamped, &rejected);
    plant.advanceTo(t + kFrameS);
    const bool zoomed = at[0].zoom >= 3.9 && at[1].zoom >= 3.9;
    run = zoomed && inBothViews(rig, at, ball, 10) ? run + 1 : 0;
    if (run >= 6) seen_s = t;
  }
  ASSERT_GE(seen_s, 0) << "never in both zoomed views";
  EXPECT_LE(seen_s, 15.0);
  EXPECT_GE(c.search().level(), 1);
  RecordProperty("seen_s", std::to_string(seen_s));
}

}  // namespace
}  // namespace ptz::control
