// ptz-detect's pipeline with fiducial markers (config/markers_tool.yaml): rendered JPEG frames of a
// tagged cube ("tool", a tag on each side), a loose ArUco tag and the red ball through
// DetectPipeline as ptz-detect runs it. Each tagged object is a track with its whole orientation,
// its detections carry its name and id in both views, and TARGET_SELECT by a tag's class follows
// it; an id the family does not have is refused.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <string>
#include <vector>

#include "common/markers.hpp"
#include "common/rig.hpp"
#include "perception/detect/detect_params.hpp"
#include "perception/detect/detect_pipeline.hpp"
#include "sim/sim_messages.hpp"
#include "sim/simulator.hpp"
#include "support/detect_pipeline.hpp"
#include "support/detect_scene.hpp"

namespace perception = ptz::perception;
namespace sim = ptz::sim;

namespace {

sim::SceneTag sceneTag(const std::string& family, int id, double size_m,
                       const Eigen::Vector3d& centre, double yaw_deg) {
  sim::SceneTag t;
  t.family = family;
  t.id = id;
  t.size_m = size_m;
  t.centre_m = centre;
  t.rotation_object_tag = ptz::tagRotation(yaw_deg, 0);
  std::string why;
  EXPECT_TRUE(ptz::markerCells(family, id, &t.cells, &why)) << why;
  return t;
}

sim::SceneObject whiteBox(const std::string& name, const Eigen::Vector3d& centre, double half_m,
                          double yaw_deg, std::vector<sim::SceneTag> tags) {
  sim::SceneObject o;
  o.name = o.class_name = name;
  o.shape = sim::SceneObject::Shape::kBox;
  o.half_extents_m = Eigen::Vector3d::Constant(half_m);
  o.yaw_rad = yaw_deg * M_PI / 180;
  o.color_bgr = {235, 235, 235};
  o.trajectory.centre_m = centre;
  o.tags = std::move(tags);
  return o;
}

const Eigen::Vector3d kToolAt(0.45, 0.1, 2.2), kArucoAt(-0.5, -0.05, 2.3), kBallAt(0, 0.3, 3);

class MarkerPipeline : public ::testing::Test {
 protected:
  void SetUp() override {
    const double h = 0.12;
    sim::Scene scene;
    scene.objects = {
        whiteBox("tool", kToolAt, h, 35,
                 {sceneTag("apriltag_36h11", 0, 0.16, {0, 0, -h}, 0),
                  sceneTag("apriltag_36h11", 1, 0.16, {h, 0, 0}, -90),
                  sceneTag("apriltag_36h11", 2, 0.16, {0, 0, h}, 180),
                  sceneTag("apriltag_36h11", 3, 0.16, {-h, 0, 0}, 90)}),
        whiteBox("tag", kArucoAt, 0.11, -25, {sceneTag("aruco_4x4_50", 5, 0.15, {0, 0, -0.11}, 0)}),
        ptz::test::object("red_ball", sim::SceneObject::Shape::kSphere, kBallAt, ptz::test::kRed)};
    scene_ = scene;
    sim::Simulator s(ptz::StereoRig::makeDefault(), scene, ptz::defaultPlantParams(), 2.0, 1);
    frame_ = sim::makeFrameMessage(s.capture(), 0, ptzstereo::image_t::ENCODING_JPEG, 90);
  }

  perception::DetectPipeline make() {
    return ptz::test::makeDetectPipeline(
        {{"markers_config", PTZ_SOURCE_DIR "/config/markers_tool.yaml"}});
  }

  perception::FrameOutputs feed(perception::DetectPipeline* pipeline) {
    return ptz::test::feedFrame(pipeline, frame_, &seq_);
  }

  sim::Scene scene_;
  ptzstereo::stereo_frame_t frame_;
  int64_t seq_ = 0;
};

const ptzstereo::object_track_t* trackOf(const perception::FrameOutputs& out,
                                         const std::string& class_name) {
  for (const auto& t : out.tracks.tracks) {
    if (t.class_name == class_name) return &t;
  }
  return nullptr;
}

double angleDeg(const double* wxyz, const Eigen::Matrix3d& truth) {
  const Eigen::Quaterniond q(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  return Eigen::AngleAxisd(q.toRotationMatrix().transpose() * truth).angle() * 180 / M_PI;
}

}  // namespace

TEST_F(MarkerPipeline, TaggedObjectsAreTracksWithTheirWholeOrientation) {
  perception::DetectPipeline pipeline = make();
  perception::FrameOutputs out;
  // Every band of the image once (8), then the tracks' confirmations.
  for (int i = 0; i < 14; ++i) out = feed(&pipeline);
  const auto* tool = trackOf(out, "tool");
  const auto* tag = trackOf(out, "aruco#5");
  ASSERT_NE(tool, nullptr);
  ASSERT_NE(tag, nullptr);
  ASSERT_NE(trackOf(out, "red_ball"), nullptr);  // the colours as before
  EXPECT_EQ(tool->state, ptzstereo::object_track_t::STATE_CONFIRMED);
  ASSERT_TRUE(tool->has_orientation);
  ASSERT_TRUE(tag->has_orientation);
  const Eigen::Matrix3d tool_R = scene_.objects[0].rotationHeadObject(0);
  const Eigen::Matrix3d tag_R = scene_.objects[1].rotationHeadObject(0);
  const Eigen::Vector3d tag_centre = kArucoAt + tag_R * Eigen::Vector3d(0, 0, -0.11);
  EXPECT_LT(angleDeg(tool->orientation_wxyz, tool_R), 1.0);
  // A lone tag 34 px wide, not zoomed in on (test_markers.cpp: within a degree once zoomed).
  EXPECT_LT(angleDeg(tag->orientation_wxyz, tag_R), 3.0);
  EXPECT_LT(
      (Eigen::Vector3d(tool->position_m[0], tool->position_m[1], tool->position_m[2]) - kToolAt)
          .norm(),
      0.003 * kToolAt.norm());
  EXPECT_LT(
      (Eigen::Vector3d(tag->position_m[0], tag->position_m[1], tag->position_m[2]) - tag_centre)
          .norm(),
      0.003 * tag_centre.norm());
  // Its rotation's covariance is a real one (not the yaw's lone y-y entry).
  EXPECT_GT(tool->orientation_covariance_rad2[0], 0);
  EXPECT_GT(tool->orientation_covariance_rad2[8], 0);

  // OBJECT_POSE: the objects with their orientation; OBJECT_DETECTIONS: each tag in both views,
  // named by its object, matched to the other view's.
  int tool_objects = 0;
  for (const auto& o : out.pose.objects) {
    if (o.class_name != "tool") continue;
    ++tool_objects;
    EXPECT_TRUE(o.has_orientation);
    ASSERT_GE(o.left_index, 0);
    ASSERT_GE(o.right_index, 0);
    EXPECT_EQ(out.detections.left.at(static_cast<size_t>(o.left_index)).class_name, "tool");
  }
  EXPECT_EQ(tool_objects, 1);
  int matched = 0;
  for (const auto& d : out.detections.left) {
    if (d.class_name != "aruco#5" && d.class_name != "tool") continue;
    ASSERT_GE(d.match_index, 0);
    EXPECT_EQ(out.detections.right.at(static_cast<size_t>(d.match_index)).class_name, d.class_name);
    ++matched;
  }
  EXPECT_GE(matched, 3);  // two faces of the tool (turned 35 degrees) and the loose tag
  // The counts the message is encoded by cover them all.
  EXPECT_EQ(out.detections.num_left, static_cast<int32_t>(out.detections.left.size()));
  EXPECT_EQ(out.detections.num_right, static_cast<int32_t>(out.detections.right.size()));
  EXPECT_EQ(out.pose.num_objects, static_cast<int32_t>(out.pose.objects.size()));
  EXPECT_GE(pipeline.counters().at("marker_objects"), 10);
  EXPECT_EQ(pipeline.counters().at("marker_bands_scanned"), 14);
  EXPECT_GT(pipeline.counters().at("track_rotations_accepted"), 10);
}

// A camera's frames do not wait for the search for new tags: it runs on its own thread, niced, and
// a frame that comes while it runs is not searched (counted). The tags are found all the same, and
// once the frames wait for it again (a repeatable run's) every frame is searched.
TEST_F(MarkerPipeline, TheSearchForNewTagsRunsBesideTheNextFrames) {
  perception::DetectPipeline pipeline = make();
  auto count = [&](const char* name) {
    const auto it = pipeline.counters().find(name);
    return it == pipeline.counters().end() ? int64_t{0} : it->second;
  };
  perception::FrameOutputs out;
  int fed = 0;
  for (; fed < 14; ++fed) out = ptz::test::feedFrame(&pipeline, frame_, &seq_, false);
  // Every frame's search either ran or was skipped, and not more than one ran at once.
  for (int i = 0; i < 10; ++i, ++fed) out = feed(&pipeline);
  EXPECT_EQ(count("marker_bands_scanned") + count("new_object_searches_skipped"), fed);
  EXPECT_GE(count("marker_bands_scanned"), 10);
  const auto* tool = trackOf(out, "tool");
  ASSERT_NE(tool, nullptr);
  ASSERT_NE(trackOf(out, "aruco#5"), nullptr);
  EXPECT_EQ(tool->state, ptzstereo::object_track_t::STATE_CONFIRMED);
  EXPECT_LT(angleDeg(tool->orientation_wxyz, scene_.objects[0].rotationHeadObject(0)), 1.0);
  // Its thread is nicer than this one by new_objects_nice_increment (10).
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  ASSERT_EQ(errno, 0);
  EXPECT_EQ(count("new_objects_thread_nice"), std::min(19, nice + 10));
  EXPECT_EQ(pipeline.newObjectsThreadProblem(), "");
}

TEST_F(MarkerPipeline, TargetSelectByATagsClass) {
  perception::DetectPipeline pipeline = make();
  perception::FrameOutputs out;
  for (int i = 0; i < 14; ++i) out = feed(&pipeline);
  ASSERT_EQ(out.tracks.target_id, trackOf(out, "red_ball")->id);  // the default target_class
  ptzstereo::target_select_t m{};
  m.mode = ptzstereo::target_select_t::MODE_CLASS;
  m.class_name = "aruco#5";
  std::string why;
  ASSERT_TRUE(pipeline.select(m, &why)) << why;
  out = feed(&pipeline);
  ASSERT_NE(trackOf(out, "aruco#5"), nullptr);
  EXPECT_EQ(out.tracks.target_id, trackOf(out, "aruco#5")->id);
  EXPECT_GE(out.pose.target_index, 0);
  EXPECT_EQ(out.pose.objects.at(static_cast<size_t>(out.pose.target_index)).class_name, "aruco#5");
  // A tag of the family not in sight: accepted, waited for; an id the family lacks: refused.
  m.class_name = "aruco#7";
  EXPECT_TRUE(pipeline.select(m, &why)) << why;
  m.class_name = "aruco#50";
  EXPECT_FALSE(pipeline.select(m, &why));
  EXPECT_NE(why.find("aruco#50"), std::string::npos) << why;
  m.class_name = "tool";
  ASSERT_TRUE(pipeline.select(m, &why)) << why;
  out = feed(&pipeline);
  EXPECT_EQ(out.tracks.target_id, trackOf(out, "tool")->id);
}
