// ptz-detect's pipeline without LCM: rendered JPEG stereo frames of objects at known places through
// DetectPipeline as ptz-detect runs it (its parameters, config/detect_default.yaml's classes, the
// default rig): the target's OBJECT_POSE position against the scene's truth, the three messages
// agreeing, the status's counters; TARGET_SELECT requests by class, track id and image point change
// the target, and those that cannot be met change nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "perception/detect/detect_params.hpp"
#include "perception/detect/detect_pipeline.hpp"
#include "sim/sim_messages.hpp"
#include "sim/simulator.hpp"
#include "support/detect_pipeline.hpp"
#include "support/detect_scene.hpp"

namespace perception = ptz::perception;
namespace sim = ptz::sim;
using ptz::test::kGreen;
using ptz::test::kRed;
using ptz::test::object;

namespace {

const cv::Vec3b kBlue(200, 80, 30);  // config/sim_default.yaml's blue ball
const Eigen::Vector3d kRedAt(0.2, 0.0, 3.0), kBlueAt(-0.5, 0.1, 2.5), kBoxAt(0.7, -0.2, 3.5);

// The red ball (the default target_class), a blue ball and a green box, the cameras at home.
sim::Scene threeObjects() {
  sim::Scene scene;
  scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, kRedAt, kRed),
                   object("blue_ball", sim::SceneObject::Shape::kSphere, kBlueAt, kBlue),
                   object("green_box", sim::SceneObject::Shape::kBox, kBoxAt, kGreen)};
  scene.objects[2].yaw_rad = 0.3;
  return scene;
}

// A frame of `scene` as ptz-sim publishes it with --encoding jpeg (restart markers and all).
ptzstereo::stereo_frame_t render(const sim::Scene& scene) {
  sim::Simulator s(ptz::StereoRig::makeDefault(), scene, ptz::defaultPlantParams(), 2.0, 1);
  return sim::makeFrameMessage(s.capture(), 0, ptzstereo::image_t::ENCODING_JPEG, 90);
}

// The three objects' frame, fed again and again to pipelines made as ptz-detect makes its own.
class Pipeline : public ::testing::Test {
 protected:
  void SetUp() override { frame_ = render(threeObjects()); }

  // A pipeline from ptz-detect's parameters (but the transport's): detect_default.yaml, the
  // default rig, and `set` (name, value) as flags would set them.
  perception::DetectPipeline make(
      const std::vector<std::pair<std::string, std::string>>& set = {}) {
    return ptz::test::makeDetectPipeline(set);
  }

  // The rendered frame again, as frame `seq` captured at 30 Hz (the objects stand still).
  perception::FrameOutputs feed(perception::DetectPipeline* pipeline) {
    return ptz::test::feedFrame(pipeline, frame_, &seq_);
  }

  ptzstereo::stereo_frame_t frame_;
  int64_t seq_ = 0;
};

// The pose's target object (throws when there is none).
const ptzstereo::object_3d_t& target(const perception::FrameOutputs& out) {
  EXPECT_GE(out.pose.target_index, 0);
  EXPECT_LT(out.pose.target_index, out.pose.num_objects);
  return out.pose.objects.at(static_cast<size_t>(out.pose.target_index));
}

Eigen::Vector3d position(const ptzstereo::object_3d_t& o) {
  return {o.position_m[0], o.position_m[1], o.position_m[2]};
}

// The track of a class in the frame's OBJECT_TRACKS (-1: none).
int64_t trackOf(const perception::FrameOutputs& out, const std::string& class_name) {
  for (const auto& t : out.tracks.tracks) {
    if (t.class_name == class_name) return t.id;
  }
  return -1;
}

int64_t counter(const perception::DetectPipeline& pipeline, const std::string& name) {
  const auto it = pipeline.counters().find(name);
  return it == pipeline.counters().end() ? 0 : it->second;
}

ptzstereo::target_select_t request(int8_t mode) {
  ptzstereo::target_select_t m{};
  m.mode = mode;
  m.frame_seq = -1;
  return m;
}

}  // namespace

TEST_F(Pipeline, TheTargetsPoseIsTheRedBallWithinHalfAPercentOfRange) {
  perception::DetectPipeline pipeline = make();
  perception::FrameOutputs out;
  for (int i = 0; i < 5; ++i) {
    out = feed(&pipeline);
    // Every output answers its frame.
    EXPECT_EQ(out.pose.frame_seq, seq_ - 1);
    EXPECT_EQ(out.tracks.frame_seq, seq_ - 1);
    EXPECT_EQ(out.detections.frame_seq, seq_ - 1);
    EXPECT_EQ(out.pose.utime, out.tracks.utime);
    EXPECT_EQ(out.pose.utime, out.detections.utime);
  }
  // Three objects in both images, paired and triangulated; each where the scene has it.
  EXPECT_EQ(out.detections.num_left, 3);
  EXPECT_EQ(out.detections.num_right, 3);
  ASSERT_EQ(out.pose.num_objects, 3);
  for (const auto& o : out.pose.objects) {
    const Eigen::Vector3d truth = o.class_name == "red_ball"    ? kRedAt
                                  : o.class_name == "blue_ball" ? kBlueAt
                                                                : kBoxAt;
    EXPECT_EQ(out.detections.left[static_cast<size_t>(o.left_index)].match_index, o.right_index);
    if (o.class_name != "green_box") {  // a box's centroids are its faces', in front of its centre
      EXPECT_LE((position(o) - truth).norm(), 0.005 * truth.norm()) << o.class_name;
      EXPECT_NEAR(o.radius_m, 0.1, 0.01) << o.class_name;
    }
  }
  // The target: the red ball (target_class), confirmed after track_confirm_hits frames.
  const ptzstereo::object_3d_t& t = target(out);
  EXPECT_EQ(t.class_name, "red_ball");
  const double error_m = (position(t) - kRedAt).norm();
  EXPECT_LE(error_m, 0.005 * kRedAt.norm()) << position(t).transpose();
  EXPECT_EQ(out.tracks.target_id, trackOf(out, "red_ball"));
  EXPECT_EQ(out.tracks.target_id, pipeline.targetId());
  EXPECT_EQ(out.tracks.num_tracks, 3);
  std::printf("target 3D error: %.1f mm at %.2f m\n", error_m * 1000, kRedAt.norm());

  // The status's counters, as ptz-detect sets them.
  const auto& c = pipeline.counters();
  EXPECT_EQ(c.at("frames_processed"), 5);
  EXPECT_EQ(c.at("frames_without_target"), 2);  // tracks confirm in the third frame
  EXPECT_EQ(c.at("target_id"), out.tracks.target_id);
  EXPECT_EQ(c.at("target_changes"), 1);
  EXPECT_EQ(c.at("tracks_live"), 3);
  EXPECT_EQ(c.at("tracks_started"), 3);
  EXPECT_GE(c.at("orientations_estimated"), 3);  // the box's yaw, in every frame it is trusted
  EXPECT_EQ(c.at("frames_scanned_full") + c.at("frames_scanned_windowed"), 5);
  for (const char* name : {"tracks_recovered", "tracks_refused", "track_yaws_accepted",
                           "track_yaws_refused", "orientation_views_decoded"}) {
    EXPECT_EQ(c.count(name), 1u) << name;
  }
  const perception::Track* box = pipeline.tracker().find(trackOf(out, "green_box"));
  ASSERT_NE(box, nullptr);
  EXPECT_TRUE(box->has_yaw);
}

// The target's colour as the status tells it: the learned hue off the red window's centre, the
// gate once learned, and a WARN when the object's hue reaches the window's edge.
TEST_F(Pipeline, TheTargetsHueIsLearnedAndItsEdgeOfRangeSaid) {
  perception::DetectPipeline red = make();
  for (int i = 0; i < 8; ++i) feed(&red);
  EXPECT_EQ(red.appearanceWarning(), "");
  EXPECT_EQ(counter(red, "appearance_out_of_range_frames"), 0);
  EXPECT_NEAR(counter(red, "color_red_ball_hue_offset_cdeg"), 0, 100);  // BGR (30, 30, 210): 0 deg
  EXPECT_GE(counter(red, "color_red_ball_gate_halfwidth_cdeg"), 400);   // active, >= 4 deg

  // BGR (30, 85, 210): hue 17.4 deg, inside 340..20, but its band (+- 4 deg at least) is not.
  sim::Scene scene;
  scene.objects = {object("red_ball", sim::SceneObject::Shape::kSphere, kRedAt, {30, 85, 210})};
  frame_ = render(scene);
  perception::DetectPipeline orange = make();
  for (int i = 0; i < 8; ++i) feed(&orange);
  EXPECT_NEAR(counter(orange, "color_red_ball_hue_offset_cdeg"), 1740, 100);
  EXPECT_NE(orange.appearanceWarning().find("class red_ball: hue 17"), std::string::npos)
      << orange.appearanceWarning();
  EXPECT_GT(counter(orange, "appearance_out_of_range_frames"), 0);
}

TEST_F(Pipeline, TheSameFramesGiveTheSameMessagesWithAndWithoutWindows) {
  perception::DetectPipeline windowed = make(), whole = make({{"windows", "false"}});
  for (int i = 0; i < 8; ++i) {
    const int64_t seq = seq_;
    const perception::FrameOutputs a = feed(&windowed);
    seq_ = seq;
    const perception::FrameOutputs b = feed(&whole);
    EXPECT_EQ(a.pose.num_objects, b.pose.num_objects) << "frame " << i;
    EXPECT_EQ(a.pose.target_index, b.pose.target_index) << "frame " << i;
    for (size_t k = 0; k < a.pose.objects.size() && k < b.pose.objects.size(); ++k) {
      EXPECT_EQ(position(a.pose.objects[k]), position(b.pose.objects[k])) << "frame " << i;
    }
  }
  EXPECT_GT(counter(windowed, "frames_scanned_windowed"), 0);
  EXPECT_EQ(counter(whole, "frames_scanned_windowed"), 0);
  EXPECT_EQ(counter(whole, "frames_scanned_full"), 8);
}

TEST_F(Pipeline, TargetSelectByClassTrackIdAndImagePointChangesTheTarget) {
  perception::DetectPipeline pipeline = make();
  std::string why;
  // Before any frame: no point can be picked.
  ptzstereo::target_select_t point = request(ptzstereo::target_select_t::MODE_IMAGE_POINT);
  point.camera = ptzstereo::target_select_t::CAMERA_LEFT;
  EXPECT_FALSE(pipeline.select(point, &why));
  EXPECT_EQ(why, "no frame seen yet");

  perception::FrameOutputs out;
  for (int i = 0; i < 4; ++i) out = feed(&pipeline);
  const int64_t red = trackOf(out, "red_ball"), blue = trackOf(out, "blue_ball");
  ASSERT_GT(red, 0);
  ASSERT_GT(blue, 0);
  ASSERT_EQ(pipeline.targetId(), red);

  // By class: the blue ball from the next frame on.
  ptzstereo::target_select_t by_class = request(ptzstereo::target_select_t::MODE_CLASS);
  by_class.class_name = "blue_ball";
  ASSERT_TRUE(pipeline.select(by_class, &why)) << why;
  EXPECT_EQ(pipeline.targetId(), -1);  // the class's confirmed track is chosen with the next frame
  out = feed(&pipeline);
  EXPECT_EQ(out.tracks.target_id, blue);
  EXPECT_EQ(target(out).class_name, "blue_ball");
  EXPECT_LE((position(target(out)) - kBlueAt).norm(), 0.005 * kBlueAt.norm());

  // By track id: back to the red ball.
  ptzstereo::target_select_t by_id = request(ptzstereo::target_select_t::MODE_TRACK_ID);
  by_id.track_id = red;
  ASSERT_TRUE(pipeline.select(by_id, &why)) << why;
  EXPECT_EQ(pipeline.targetId(), red);
  out = feed(&pipeline);
  EXPECT_EQ(out.tracks.target_id, red);
  EXPECT_EQ(target(out).class_name, "red_ball");

  // By image point: the blue ball where the right camera sees it.
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  const Eigen::Vector2d px = rig.view(ptz::Side::kRight, {}).project(kBlueAt);
  point.camera = ptzstereo::target_select_t::CAMERA_RIGHT;
  point.x_px = px.x();
  point.y_px = px.y();
  ASSERT_TRUE(pipeline.select(point, &why)) << why;
  EXPECT_EQ(pipeline.targetId(), blue);
  out = feed(&pipeline);
  EXPECT_EQ(out.tracks.target_id, blue);
  EXPECT_EQ(out.tracks.target_reason, pipeline.targetReason());

  // Refused, each with its reason; the target stays.
  ptzstereo::target_select_t unknown = by_class;
  unknown.class_name = "purple_ball";
  EXPECT_FALSE(pipeline.select(unknown, &why));
  EXPECT_NE(why.find("purple_ball"), std::string::npos) << why;
  ptzstereo::target_select_t gone = by_id;
  gone.track_id = 1'000'000;
  EXPECT_FALSE(pipeline.select(gone, &why));
  ptzstereo::target_select_t no_camera = point;
  no_camera.camera = 2;
  EXPECT_FALSE(pipeline.select(no_camera, &why));
  EXPECT_EQ(why, "camera 2 is neither 0 nor 1");
  ptzstereo::target_select_t no_mode = request(7);
  EXPECT_FALSE(pipeline.select(no_mode, &why));
  EXPECT_EQ(why, "mode 7 is none of 0, 1, 2");
  EXPECT_EQ(pipeline.targetId(), blue);
  out = feed(&pipeline);
  EXPECT_EQ(out.tracks.target_id, blue);
}
