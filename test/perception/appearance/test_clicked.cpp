// An object picked by a click, on frames rendered by the simulator (JPEG, sensor noise): a
// textured plate no colour class takes is found in the other view along the click's epipolar line
// and followed as it moves, against its true position; a flat patch, a click at the border and two
// plates alike along the line are refused. Then through ptz-detect's pipeline: a click on no track
// makes the clicked object the target.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "perception/appearance/clicked.hpp"
#include "sim/sim_messages.hpp"
#include "sim/simulator.hpp"
#include "support/detect_pipeline.hpp"
#include "support/render_aimed.hpp"

namespace perception = ptz::perception;
namespace sim = ptz::sim;
using ptz::Side;

namespace {

sim::SceneObject plate(const std::string& name, const Eigen::Vector3d& centre, bool textured) {
  sim::SceneObject o;
  o.name = o.class_name = name;
  o.shape = sim::SceneObject::Shape::kBox;
  o.half_extents_m = {0.15, 0.15, 0.005};
  o.yaw_rad = 0.2;
  o.color_bgr = {150, 165, 175};
  o.textured = textured;
  o.trajectory.centre_m = centre;
  return o;
}

}  // namespace

TEST(Clicked, StartsOnATexturedPlateAndFollowsIt) {
  sim::Scene scene;
  scene.objects = {plate("plate", {0.2, 0.05, 2.5}, true)};
  scene.objects[0].trajectory.type = sim::Trajectory::Type::kLine;
  scene.objects[0].trajectory.amplitude_m = {0.5, 0.1, 0.2};
  scene.objects[0].trajectory.period_s = 8;
  perception::ClickedTracker tracker;
  ptz::test::FrameCrops c;
  ptz::test::AimedFrame f = ptz::test::renderAtHome(scene, 0);
  c.images[0] = f.left;
  c.images[1] = f.right;
  const Eigen::Vector3d at0 = scene.objects[0].trajectory.position(0);
  const Eigen::Vector2d click = f.left_view.project(at0);
  perception::PatchObject first;
  std::string why;
  ASSERT_TRUE(tracker.start(Side::kLeft, click, c.crop, f.left_view, f.right_view, &first, &why))
      << why;
  // The plate's face is 5 mm in front of its centre.
  EXPECT_LT((first.position_m - at0).norm(), 0.003 * at0.norm() + 0.005);
  EXPECT_GT(first.score[1], 0.9);
  EXPECT_NEAR(first.radius_m, 24 * 2.5 / 500, 0.01);  // half the 48 px patch at 2.5 m, f 500
  // A frame at a time, 1 s: it moves 0.25 m sideways and comes 0.1 m nearer.
  for (int k = 1; k <= 30; ++k) {
    const double t = k / 30.0;
    f = ptz::test::renderAtHome(scene, t);
    c.images[0] = f.left;
    c.images[1] = f.right;
    const auto o = tracker.find(nullptr, t, c.crop, f.left_view, f.right_view, &why);
    ASSERT_TRUE(o.has_value()) << "frame " << k << ": " << why;
    const Eigen::Vector3d truth = scene.objects[0].trajectory.position(t);
    EXPECT_LT((o->position_m - truth).norm(), 0.003 * truth.norm() + 0.005) << "frame " << k;
  }
}

TEST(Clicked, RefusesWhatItCannotModel) {
  sim::Scene scene;
  scene.objects = {plate("flat", {-0.3, 0, 2.0}, false)};
  scene.objects[0].half_extents_m = {0.2, 0.2, 0.005};
  const ptz::test::AimedFrame f = ptz::test::renderAtHome(scene, 0);
  ptz::test::FrameCrops c;
  c.images[0] = f.left;
  c.images[1] = f.right;
  perception::ClickedTracker tracker;
  perception::PatchObject o;
  std::string why;
  const Eigen::Vector2d on_flat = f.left_view.project(scene.objects[0].trajectory.centre_m);
  EXPECT_FALSE(tracker.start(Side::kLeft, on_flat, c.crop, f.left_view, f.right_view, &o, &why));
  EXPECT_NE(why.find("flat"), std::string::npos) << why;
  EXPECT_FALSE(tracker.active());
  EXPECT_FALSE(tracker.start(Side::kLeft, {3, 200}, c.crop, f.left_view, f.right_view, &o, &why));
  EXPECT_NE(why.find("leaves the image"), std::string::npos) << why;
  EXPECT_FALSE(tracker.find(nullptr, 0, c.crop, f.left_view, f.right_view, &why).has_value());

  // The right camera zoomed in twice as far, the click near the top: the other view's patch
  // (twice the size) must fit along its line, or the click is refused (it once threw).
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  const ptz::CameraView lz = rig.view(Side::kLeft, {0, 0, 1}),
                        rz = rig.view(Side::kRight, {0, 0, 2});
  for (const double y : {135.0, 140.0, 30.0, 450.0}) {
    EXPECT_NO_THROW(tracker.start(Side::kLeft, {320, y}, c.crop, lz, rz, &o, &why)) << y;
  }

  // Two plates of one texture side by side at one range: clicked on the right one, the left one
  // is on its line in the right view too (nearer along the click's ray), alike.
  sim::Scene twins;
  twins.objects = {plate("a", {-0.25, 0, 2.5}, true), plate("b", {0.25, 0, 2.5}, true)};
  twins.objects[0].yaw_rad = twins.objects[1].yaw_rad = 0;
  const ptz::test::AimedFrame g = ptz::test::renderAtHome(twins, 0);
  c.images[0] = g.left;
  c.images[1] = g.right;
  const Eigen::Vector2d on_a = g.left_view.project(twins.objects[1].trajectory.centre_m);
  EXPECT_FALSE(tracker.start(Side::kLeft, on_a, c.crop, g.left_view, g.right_view, &o, &why));
  EXPECT_NE(why.find("alike"), std::string::npos) << why;
}

TEST(Clicked, AClickOnNoTrackMakesThePatchObjectTheTarget) {
  sim::Scene scene;
  scene.objects = {plate("plate", {0.3, 0.0, 2.5}, true)};
  sim::Simulator s(ptz::StereoRig::makeDefault(), scene, ptz::defaultPlantParams(), 2.0, 1);
  const ptzstereo::stereo_frame_t frame =
      sim::makeFrameMessage(s.capture(), 0, ptzstereo::image_t::ENCODING_JPEG, 90);
  perception::DetectPipeline pipeline = ptz::test::makeDetectPipeline();
  int64_t seq = 0;
  perception::FrameOutputs out = ptz::test::feedFrame(&pipeline, frame, &seq);
  const Eigen::Vector2d px = ptz::StereoRig::makeDefault()
                                 .view(Side::kLeft, {})
                                 .project(scene.objects[0].trajectory.centre_m);
  ptzstereo::target_select_t m{};
  m.mode = ptzstereo::target_select_t::MODE_IMAGE_POINT;
  m.camera = ptzstereo::target_select_t::CAMERA_LEFT;
  m.x_px = px.x();
  m.y_px = px.y();
  m.frame_seq = -1;
  std::string why;
  ASSERT_TRUE(pipeline.select(m, &why)) << why;
  out = ptz::test::feedFrame(&pipeline, frame, &seq);
  EXPECT_NE(out.click_note.find("a model"), std::string::npos) << out.click_note;
  for (int i = 0; i < 4; ++i) out = ptz::test::feedFrame(&pipeline, frame, &seq);
  ASSERT_GE(out.pose.target_index, 0);
  const auto& target = out.pose.objects.at(static_cast<size_t>(out.pose.target_index));
  EXPECT_EQ(target.class_name, "clicked");
  const Eigen::Vector3d p(target.position_m[0], target.position_m[1], target.position_m[2]);
  EXPECT_LT((p - scene.objects[0].trajectory.centre_m).norm(), 0.01);
  EXPECT_EQ(pipeline.counters().at("click_models_started"), 1);
  // Its patch is a detection in both views, matched.
  const auto& l = out.detections.left.at(static_cast<size_t>(target.left_index));
  EXPECT_EQ(l.class_name, "clicked");
  EXPECT_EQ(l.match_index, target.right_index);
  // A click on the clicked track selects it; one whose patch would leave the image is refused with
  // the next frame, and the target stays.
  const int64_t first_id = out.tracks.target_id;
  ASSERT_TRUE(pipeline.select(m, &why)) << why;  // on the clicked track: selects it
  EXPECT_EQ(pipeline.targetId(), first_id);
  ptzstereo::target_select_t edge = m;
  edge.x_px = 2;  // the patch would leave the image
  ASSERT_TRUE(pipeline.select(edge, &why)) << why;
  out = ptz::test::feedFrame(&pipeline, frame, &seq);
  EXPECT_NE(out.click_note.find("no model"), std::string::npos) << out.click_note;
  EXPECT_EQ(out.tracks.target_id, first_id);  // the target stays
  EXPECT_EQ(pipeline.counters().at("click_models_refused"), 1);
  // A request by class forgets a pending click.
  ptzstereo::target_select_t shifted = m;
  shifted.x_px += 40;  // beside the plate's track, on the backdrop
  ASSERT_TRUE(pipeline.select(shifted, &why)) << why;
  ptzstereo::target_select_t by_class{};
  by_class.mode = ptzstereo::target_select_t::MODE_CLASS;
  by_class.class_name = "clicked";
  ASSERT_TRUE(pipeline.select(by_class, &why)) << why;
  out = ptz::test::feedFrame(&pipeline, frame, &seq);
  EXPECT_TRUE(out.click_note.empty()) << out.click_note;
  EXPECT_EQ(pipeline.counters().at("click_models_started"), 1);
  // A click that names a frame no longer held is refused.
  ptzstereo::target_select_t old = m;
  old.frame_seq = 0;
  for (int i = 0; i < 40; ++i) ptz::test::feedFrame(&pipeline, frame, &seq);
  old.x_px += 40;
  EXPECT_FALSE(pipeline.select(old, &why));
  EXPECT_NE(why.find("not one of the last"), std::string::npos) << why;

  // With click_to_track off, a point on no track is refused as before.
  perception::DetectPipeline off = ptz::test::makeDetectPipeline({{"click_to_track", "false"}});
  ptz::test::feedFrame(&off, frame, &seq);
  EXPECT_FALSE(off.select(m, &why));
  EXPECT_EQ(why, "no confirmed track under the point");
}
