// Writes one message of every project type to an LCM log, each on a channel named after its type,
// with known field values; test/lcmtypes/DecodeAll.java decodes them with the types jar, as lcm-spy
// does.
#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <vector>

#include "ptzstereo/camera_model_t.hpp"
#include "ptzstereo/channel_status_t.hpp"
#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/counter_t.hpp"
#include "ptzstereo/detection_2d_t.hpp"
#include "ptzstereo/image_t.hpp"
#include "ptzstereo/object_3d_t.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_track_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/point_cloud_t.hpp"
#include "ptzstereo/point_field_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_head_setpoint_t.hpp"
#include "ptzstereo/ptz_head_state_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_object_truth_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "ptzstereo/target_select_t.hpp"

namespace {

lcm::LogFile* g_log = nullptr;
int64_t g_count = 0;

template <typename T>
void write(const char* channel, const T& msg) {
  std::vector<uint8_t> buf(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
  lcm::LogEvent ev{};
  ev.eventnum = g_count++;
  ev.timestamp = 1000 + g_count;
  ev.channel = channel;
  ev.datalen = static_cast<int32_t>(buf.size());
  ev.data = buf.data();
  g_log->writeEvent(&ev);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s LOGFILE\n", argv[0]);
    return 2;
  }
  lcm::LogFile log(argv[1], "w");
  if (!log.good()) return 1;
  g_log = &log;
  using namespace ptzstereo;
  image_t img{};
  img.width = 2;
  img.height = 1;
  img.row_stride = 6;
  img.pixel_format = image_t::PIXEL_BGR8;
  img.zoom = 2.5;
  img.data = {1, 2, 3, 4, 5, 6};
  img.data_size = 6;
  write("image_t", img);
  stereo_frame_t frame{};
  frame.seq = 42;
  frame.left = img;
  frame.right = img;
  write("stereo_frame_t", frame);
  ptz_head_state_t head{};
  head.pan_rad = 0.5;
  write("ptz_head_state_t", head);
  ptz_state_t state{};
  state.left = head;
  state.right = head;
  write("ptz_state_t", state);
  ptz_head_setpoint_t hs{};
  hs.zoom = 3;
  write("ptz_head_setpoint_t", hs);
  ptz_setpoint_t sp{};
  sp.frame_seq = 42;
  sp.left = hs;
  sp.right = hs;
  write("ptz_setpoint_t", sp);
  detection_2d_t det{};
  det.class_name = "red_ball";
  det.centroid_x_px = 320.5;
  write("detection_2d_t", det);
  object_detections_t dets{};
  dets.num_left = 1;
  dets.left = {det};
  write("object_detections_t", dets);
  object_3d_t obj{};
  obj.class_name = "red_ball";
  obj.position_m[2] = 3;
  obj.has_orientation = true;
  obj.orientation_wxyz[0] = 0.5;
  obj.orientation_wxyz[2] = -0.5;
  obj.orientation_covariance_rad2[4] = 0.01;
  write("object_3d_t", obj);
  object_pose_t pose{};
  pose.num_objects = 1;
  pose.objects = {obj};
  write("object_pose_t", pose);
  object_track_t track{};
  track.id = 7;
  track.class_name = "green_box";
  track.state = object_track_t::STATE_COASTING;
  track.velocity_m_s[0] = -0.25;
  track.has_orientation = true;
  track.orientation_wxyz[0] = 1;
  write("object_track_t", track);
  object_tracks_t tracks{};
  tracks.frame_seq = 42;
  tracks.target_id = 7;
  tracks.target_reason = "locked on track 7 (green_box) by track id";
  tracks.num_tracks = 2;
  tracks.tracks = {track, track};
  tracks.tracks[1].id = 8;
  write("object_tracks_t", tracks);
  target_select_t select{};
  select.mode = target_select_t::MODE_IMAGE_POINT;
  select.camera = target_select_t::CAMERA_RIGHT;
  select.x_px = 412.5;
  select.frame_seq = -1;
  write("target_select_t", select);
  control_state_t control{};
  control.frame_seq = 42;
  control.state = control_state_t::STATE_COASTING;
  control.target_id = 7;
  control.since_target_s = 0.25;
  control.search_waypoint = -1;
  control.reason = "target hidden: following its prediction";
  write("control_state_t", control);
  point_field_t field{};
  field.name = "x";
  field.datatype = point_field_t::FLOAT32;
  field.count = 1;
  write("point_field_t", field);
  point_cloud_t cloud{};
  cloud.frame_id = "head";
  cloud.num_fields = 1;
  cloud.fields = {field};
  cloud.width = 1;
  cloud.height = 1;
  cloud.point_step = 4;
  cloud.row_step = 4;
  cloud.data = {0, 0, 128, 63};
  cloud.data_size = 4;
  write("point_cloud_t", cloud);
  camera_model_t cam{};
  cam.fx_px = 500;
  write("camera_model_t", cam);
  sim_object_truth_t ot{};
  ot.name = "ball";
  ot.class_name = "red_ball";
  ot.shape = "box";
  ot.orientation_wxyz[0] = 0.25;
  ot.orientation_wxyz[2] = 0.75;
  ot.visible_fraction[1] = 0.625;
  write("sim_object_truth_t", ot);
  sim_truth_t truth{};
  truth.left_camera = cam;
  truth.right_camera = cam;
  truth.num_objects = 1;
  truth.objects = {ot};
  write("sim_truth_t", truth);
  channel_status_t ch{};
  ch.channel = "STEREO_FRAME";
  ch.rate_hz = 30;
  write("channel_status_t", ch);
  counter_t counter{"frames_published", 300};
  write("counter_t", counter);
  process_status_t status{};
  status.process = "ptz-sim";
  status.num_channels = 1;
  status.channels = {ch};
  status.num_counters = 1;
  status.counters = {counter};
  write("process_status_t", status);
  std::printf("wrote %lld messages\n", static_cast<long long>(g_count));
  return 0;
}
