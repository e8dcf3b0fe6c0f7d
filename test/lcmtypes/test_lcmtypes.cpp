// Every message type survives encode/decode; a frame decodes to the same image in both
// encodings (JPEG within its loss).
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

#include "common/transport/transport.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/point_cloud_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"

namespace {

template <typename T>
T roundTrip(const T& in) {
  std::vector<uint8_t> buf(static_cast<size_t>(in.getEncodedSize()));
  EXPECT_EQ(in.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  T out;
  EXPECT_EQ(out.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  std::vector<uint8_t> again(static_cast<size_t>(out.getEncodedSize()));
  out.encode(again.data(), 0, static_cast<int>(again.size()));
  EXPECT_EQ(buf, again);
  return out;
}

cv::Mat testImage() {
  cv::Mat img(480, 640, CV_8UC3);
  cv::RNG rng(3);
  cv::Mat small(30, 40, CV_8UC3);
  rng.fill(small, cv::RNG::UNIFORM, 0, 255);
  cv::resize(small, img, img.size(), 0, 0, cv::INTER_CUBIC);
  return img;
}

}  // namespace

TEST(LcmTypes, StereoFrameRoundTrip) {
  ptzstereo::stereo_frame_t f{};
  f.utime = 1234567;
  f.publish_utime = 1234999;
  f.seq = 42;
  f.left = ptz::encodeImage(testImage(), ptzstereo::image_t::ENCODING_RAW, 90);
  f.left.pan_rad = 0.25;
  f.left.tilt_rad = -0.125;
  f.left.zoom = 3.5;
  f.right = ptz::encodeImage(testImage(), ptzstereo::image_t::ENCODING_JPEG, 90);
  auto out = roundTrip(f);
  EXPECT_EQ(out.seq, 42);
  EXPECT_EQ(out.left.data, f.left.data);
  EXPECT_DOUBLE_EQ(out.left.pan_rad, 0.25);
  EXPECT_DOUBLE_EQ(out.left.zoom, 3.5);
  EXPECT_EQ(out.right.encoding, ptzstereo::image_t::ENCODING_JPEG);
}

TEST(LcmTypes, StateAndSetpointRoundTrip) {
  ptzstereo::ptz_state_t s{};
  s.utime = 5;
  s.left.pan_rad = 0.5;
  s.right.zoom_rate_per_s = -1.5;
  s.right.at_limit = true;
  s.setpoint_utime = 4;
  auto so = roundTrip(s);
  EXPECT_DOUBLE_EQ(so.left.pan_rad, 0.5);
  EXPECT_TRUE(so.right.at_limit);
  ptzstereo::ptz_setpoint_t sp{};
  sp.utime = 9;
  sp.frame_seq = 3;
  sp.left.tilt_rad = 0.1;
  sp.right.zoom = 4;
  auto spo = roundTrip(sp);
  EXPECT_EQ(spo.frame_seq, 3);
  EXPECT_DOUBLE_EQ(spo.right.zoom, 4);
}

TEST(LcmTypes, DetectionsAndPoseRoundTrip) {
  ptzstereo::object_detections_t d{};
  d.frame_seq = 7;
  ptzstereo::detection_2d_t det{};
  det.class_name = "red_ball";
  det.centroid_x_px = 320.25;
  det.match_index = 0;
  d.left = {det, det};
  d.num_left = 2;
  d.right = {det};
  d.num_right = 1;
  auto dout = roundTrip(d);
  ASSERT_EQ(dout.num_left, 2);
  EXPECT_EQ(dout.left[1].class_name, "red_ball");
  EXPECT_DOUBLE_EQ(dout.right[0].centroid_x_px, 320.25);

  ptzstereo::object_pose_t p{};
  ptzstereo::object_3d_t o{};
  o.class_name = "red_ball";
  o.position_m[2] = 3.0;
  o.covariance_m2[8] = 1e-4;
  o.has_orientation = true;
  o.orientation_wxyz[0] = 0.5;
  o.orientation_wxyz[2] = -0.5;
  o.orientation_covariance_rad2[4] = 0.01;
  p.objects = {o, o};
  p.objects[1].has_orientation = false;
  p.num_objects = 2;
  p.target_index = 0;
  auto pout = roundTrip(p);
  EXPECT_DOUBLE_EQ(pout.objects[0].position_m[2], 3.0);
  EXPECT_TRUE(pout.objects[0].has_orientation);
  EXPECT_FALSE(pout.objects[1].has_orientation);
  EXPECT_DOUBLE_EQ(pout.objects[0].orientation_wxyz[0], 0.5);
  EXPECT_DOUBLE_EQ(pout.objects[0].orientation_wxyz[2], -0.5);
  EXPECT_DOUBLE_EQ(pout.objects[0].orientation_covariance_rad2[4], 0.01);
  EXPECT_DOUBLE_EQ(pout.objects[0].covariance_m2[8], 1e-4);
}

TEST(LcmTypes, TracksAndTargetSelectRoundTrip) {
  ptzstereo::object_tracks_t m{};
  m.utime = 1234567;
  m.frame_seq = 7;
  m.left_ptz.zoom = 2.5;
  m.target_id = 3;
  m.target_reason = "locked on track 3 (red_ball) by class";
  ptzstereo::object_track_t t{};
  t.id = 3;
  t.class_name = "red_ball";
  t.state = ptzstereo::object_track_t::STATE_CONFIRMED;
  t.position_m[2] = 3.0;
  t.position_covariance_m2[8] = 1e-4;
  t.velocity_m_s[0] = 0.4;
  t.velocity_covariance_m2_s2[4] = 1e-2;
  t.acceleration_m_s2[1] = -0.5;
  t.radius_m = 0.1;
  t.age_s = 5.25;
  t.since_update_s = 0.125;
  t.object_index = 1;
  t.untrusted_updates = 2;
  m.tracks = {t, t};
  m.tracks[1].id = 4;
  m.tracks[1].class_name = "green_box";
  m.tracks[1].state = ptzstereo::object_track_t::STATE_COASTING;
  m.tracks[1].object_index = -1;
  m.tracks[1].has_orientation = true;
  m.tracks[1].orientation_wxyz[0] = 0.5;
  m.tracks[1].orientation_wxyz[3] = -0.5;
  m.tracks[1].orientation_covariance_rad2[8] = 0.01;
  m.num_tracks = 2;
  auto out = roundTrip(m);
  EXPECT_EQ(out.frame_seq, 7);
  EXPECT_DOUBLE_EQ(out.left_ptz.zoom, 2.5);
  EXPECT_EQ(out.target_id, 3);
  EXPECT_EQ(out.target_reason, "locked on track 3 (red_ball) by class");
  ASSERT_EQ(out.num_tracks, 2);
  ASSERT_EQ(out.tracks.size(), 2u);
  const ptzstereo::object_track_t& a = out.tracks[0];
  EXPECT_EQ(a.id, 3);
  EXPECT_EQ(a.class_name, "red_ball");
  EXPECT_EQ(a.state, ptzstereo::object_track_t::STATE_CONFIRMED);
  EXPECT_DOUBLE_EQ(a.position_m[2], 3.0);
  EXPECT_DOUBLE_EQ(a.position_covariance_m2[8], 1e-4);
  EXPECT_DOUBLE_EQ(a.velocity_m_s[0], 0.4);
  EXPECT_DOUBLE_EQ(a.velocity_covariance_m2_s2[4], 1e-2);
  EXPECT_DOUBLE_EQ(a.acceleration_m_s2[1], -0.5);
  EXPECT_DOUBLE_EQ(a.radius_m, 0.1);
  EXPECT_DOUBLE_EQ(a.age_s, 5.25);
  EXPECT_DOUBLE_EQ(a.since_update_s, 0.125);
  EXPECT_EQ(a.object_index, 1);
  EXPECT_EQ(a.untrusted_updates, 2);
  EXPECT_FALSE(a.has_orientation);
  const ptzstereo::object_track_t& b = out.tracks[1];
  EXPECT_EQ(b.id, 4);
  EXPECT_EQ(b.class_name, "green_box");
  EXPECT_EQ(b.state, ptzstereo::object_track_t::STATE_COASTING);
  EXPECT_EQ(b.object_index, -1);
  EXPECT_TRUE(b.has_orientation);
  EXPECT_DOUBLE_EQ(b.orientation_wxyz[0], 0.5);
  EXPECT_DOUBLE_EQ(b.orientation_wxyz[3], -0.5);
  EXPECT_DOUBLE_EQ(b.orientation_covariance_rad2[8], 0.01);

  ptzstereo::target_select_t s{};
  s.utime = 99;
  s.mode = ptzstereo::target_select_t::MODE_IMAGE_POINT;
  s.class_name = "red_ball";
  s.track_id = -1;
  s.camera = ptzstereo::target_select_t::CAMERA_RIGHT;
  s.x_px = 412.5;
  s.y_px = 230.25;
  s.frame_seq = -1;
  auto sout = roundTrip(s);
  EXPECT_EQ(sout.utime, 99);
  EXPECT_EQ(sout.mode, ptzstereo::target_select_t::MODE_IMAGE_POINT);
  EXPECT_EQ(sout.class_name, "red_ball");
  EXPECT_EQ(sout.track_id, -1);
  EXPECT_EQ(sout.camera, ptzstereo::target_select_t::CAMERA_RIGHT);
  EXPECT_DOUBLE_EQ(sout.x_px, 412.5);
  EXPECT_DOUBLE_EQ(sout.y_px, 230.25);
  EXPECT_EQ(sout.frame_seq, -1);
}

TEST(LcmTypes, ControlStateRoundTrip) {
  ptzstereo::control_state_t m{};
  m.utime = 1234567;
  m.publish_utime = 1256789;
  m.frame_seq = 7;
  m.state = ptzstereo::control_state_t::STATE_SEARCHING;
  m.target_id = -1;
  m.since_target_s = 1.5;
  m.search_waypoint = 2;
  m.search_waypoints = 8;
  m.reason = "no target: searching, waypoint 3 of 8";
  auto out = roundTrip(m);
  EXPECT_EQ(out.utime, 1234567);
  EXPECT_EQ(out.publish_utime, 1256789);
  EXPECT_EQ(out.frame_seq, 7);
  EXPECT_EQ(out.state, ptzstereo::control_state_t::STATE_SEARCHING);
  EXPECT_EQ(out.target_id, -1);
  EXPECT_DOUBLE_EQ(out.since_target_s, 1.5);
  EXPECT_EQ(out.search_waypoint, 2);
  EXPECT_EQ(out.search_waypoints, 8);
  EXPECT_EQ(out.reason, "no target: searching, waypoint 3 of 8");
}

TEST(LcmTypes, PointCloudTruthStatusRoundTrip) {
  ptzstereo::point_cloud_t c{};
  c.frame_id = "head";
  c.width = 2;
  c.height = 1;
  for (const char* n : {"x", "y", "z"}) {
    ptzstereo::point_field_t f{};
    f.name = n;
    f.offset = 4 * static_cast<int>(c.fields.size());
    f.datatype = ptzstereo::point_field_t::FLOAT32;
    f.count = 1;
    c.fields.push_back(f);
  }
  c.num_fields = 3;
  c.point_step = 12;
  c.row_step = 24;
  c.data.assign(24, 0xAB);
  c.data_size = 24;
  auto cout = roundTrip(c);
  EXPECT_EQ(cout.fields[2].name, "z");
  EXPECT_EQ(cout.fields[2].offset, 8);

  ptzstereo::sim_truth_t t{};
  ptzstereo::sim_object_truth_t ot{};
  ot.name = "ball";
  ot.class_name = "red_ball";
  ot.shape = "sphere";
  ot.position_m[0] = 1.5;
  ot.orientation_wxyz[0] = 0.25;
  ot.orientation_wxyz[2] = 0.75;
  ot.visible_fraction[0] = 0.5;
  t.objects = {ot};
  t.num_objects = 1;
  t.left_camera.fx_px = 500;
  auto tout = roundTrip(t);
  EXPECT_DOUBLE_EQ(tout.objects[0].position_m[0], 1.5);
  EXPECT_DOUBLE_EQ(tout.objects[0].orientation_wxyz[0], 0.25);
  EXPECT_DOUBLE_EQ(tout.objects[0].orientation_wxyz[2], 0.75);
  EXPECT_DOUBLE_EQ(tout.objects[0].visible_fraction[0], 0.5);
  EXPECT_DOUBLE_EQ(tout.left_camera.fx_px, 500);

  ptzstereo::process_status_t s{};
  s.process = "ptz-sim";
  ptzstereo::channel_status_t ch{};
  ch.channel = "STEREO_FRAME";
  ch.rate_hz = 30;
  s.channels = {ch};
  s.num_channels = 1;
  s.counters = {{"frames_published", 300}};
  s.num_counters = 1;
  auto sout = roundTrip(s);
  EXPECT_EQ(sout.channels[0].channel, "STEREO_FRAME");
  EXPECT_EQ(sout.counters[0].value, 300);
}

TEST(ImageCodec, RawAndJpegDecodeToTheSameImage) {
  const cv::Mat img = testImage();
  cv::Mat raw, jpeg;
  std::string error;
  ASSERT_TRUE(
      ptz::decodeImage(ptz::encodeImage(img, ptzstereo::image_t::ENCODING_RAW, 90), &raw, &error))
      << error;
  ASSERT_TRUE(
      ptz::decodeImage(ptz::encodeImage(img, ptzstereo::image_t::ENCODING_JPEG, 90), &jpeg, &error))
      << error;
  EXPECT_EQ(cv::norm(raw, img, cv::NORM_INF), 0);
  cv::Mat diff;
  cv::absdiff(jpeg, img, diff);
  EXPECT_LT(cv::mean(diff)[0], 2.0);  // JPEG q90 on a smooth image: about 1 grey level
  EXPECT_LT(cv::norm(jpeg, img, cv::NORM_INF), 40);
}

TEST(ImageCodec, RowStrideIsHonoured) {
  const cv::Mat img = testImage();
  ptzstereo::image_t msg = ptz::encodeImage(img, ptzstereo::image_t::ENCODING_RAW, 90);
  // Re-pack with 16 bytes of padding per row.
  const int stride = msg.row_stride + 16;
  std::vector<uint8_t> padded(static_cast<size_t>(stride) * msg.height, 0);
  for (int r = 0; r < msg.height; ++r) {
    std::copy_n(msg.data.begin() + static_cast<ptrdiff_t>(r) * msg.row_stride, msg.row_stride,
                padded.begin() + static_cast<ptrdiff_t>(r) * stride);
  }
  msg.data = padded;
  msg.data_size = static_cast<int32_t>(padded.size());
  msg.row_stride = stride;
  cv::Mat out;
  std::string error;
  ASSERT_TRUE(ptz::decodeImage(msg, &out, &error)) << error;
  EXPECT_EQ(cv::norm(out, img, cv::NORM_INF), 0);
}

TEST(ImageCodec, BadImagesAreRefusedWithAReason) {
  const cv::Mat img = testImage();
  cv::Mat out;
  std::string error;
  auto raw = ptz::encodeImage(img, ptzstereo::image_t::ENCODING_RAW, 90);

  auto truncated = raw;
  truncated.data.resize(truncated.data.size() / 2);
  truncated.data_size = static_cast<int32_t>(truncated.data.size());
  EXPECT_FALSE(ptz::decodeImage(truncated, &out, &error));
  EXPECT_NE(error.find("truncated"), std::string::npos) << error;

  auto unknown = raw;
  unknown.encoding = 9;
  EXPECT_FALSE(ptz::decodeImage(unknown, &out, &error));
  EXPECT_NE(error.find("encoding"), std::string::npos) << error;

  auto wrong_size = ptz::encodeImage(img, ptzstereo::image_t::ENCODING_JPEG, 90);
  wrong_size.width = 320;
  EXPECT_FALSE(ptz::decodeImage(wrong_size, &out, &error));

  auto garbage = ptz::encodeImage(img, ptzstereo::image_t::ENCODING_JPEG, 90);
  std::fill(garbage.data.begin(), garbage.data.end(), 0x5A);
  EXPECT_FALSE(ptz::decodeImage(garbage, &out, &error));

  auto nan_pose = raw;
  nan_pose.pan_rad = std::nan("");
  EXPECT_FALSE(ptz::decodeImage(nan_pose, &out, &error));
  EXPECT_NE(error.find("non-finite"), std::string::npos) << error;
}
