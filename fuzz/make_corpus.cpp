// Writes the seed corpus of every fuzz target (fuzz/corpus/<target>/): real encoded messages,
// JPEGs encoded by OpenCV, the VISCA and Pelco-D bytes the project's own encoders and camera
// emulators produce, the ONVIF requests ptz-sim's cameras take, the project's config, model and
// rig files, small LCM logs, masks of discs and images with fiducial tags. Deterministic;
// `scripts/fuzz --make-corpus` runs it. Usage: ptz_fuzz_corpus SOURCE_DIR CORPUS_DIR
#include <lcm/lcm-cpp.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "common/rig.hpp"
#include "common/transport/transport.hpp"
#include "ptz_driver/emulators/visca_camera_emulator.hpp"
#include "ptz_driver/heads/onvif/ws_security.hpp"
#include "ptz_driver/heads/pelco_d/pelco_d.hpp"
#include "ptz_driver/heads/visca/visca.hpp"
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

using ptz::driver::Bytes;
namespace visca = ptz::driver::visca;
namespace visca_ip = ptz::driver::visca_ip;
namespace pelco_d = ptz::driver::pelco_d;

std::string g_out;
// Every message seed, as a record of fuzz_foxglove_convert's input: [channel byte][u16 LE][bytes].
Bytes g_convert_records;

void addConvertRecord(const std::string& target, const Bytes& bytes) {
  // The channel bytes of fuzz_foxglove_convert.cpp's table.
  static const std::map<std::string, uint8_t> channel_byte = {
      {"fuzz_stereo_frame", 0},  {"fuzz_ptz_state", 2},         {"fuzz_ptz_setpoint", 3},
      {"fuzz_control_state", 4}, {"fuzz_object_detections", 5}, {"fuzz_object_pose", 6},
      {"fuzz_object_tracks", 7}, {"fuzz_sim_truth", 8},         {"fuzz_target_select", 9},
      {"fuzz_point_cloud", 10},  {"fuzz_process_status", 13}};
  const auto it = channel_byte.find(target);
  if (it == channel_byte.end() || bytes.size() > 0xFFFF) return;
  g_convert_records.push_back(it->second);
  g_convert_records.push_back(static_cast<uint8_t>(bytes.size() & 0xFF));
  g_convert_records.push_back(static_cast<uint8_t>(bytes.size() >> 8));
  g_convert_records.insert(g_convert_records.end(), bytes.begin(), bytes.end());
}

void write(const std::string& target, const std::string& name, const Bytes& bytes) {
  addConvertRecord(target, bytes);
  const std::string dir = g_out + "/" + target;
  ::mkdir(dir.c_str(), 0755);
  std::ofstream f(dir + "/" + name, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!f) {
    std::fprintf(stderr, "cannot write %s/%s\n", dir.c_str(), name.c_str());
    std::exit(1);
  }
}
void write(const std::string& target, const std::string& name, const std::string& text) {
  write(target, name, Bytes(text.begin(), text.end()));
}

Bytes readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    std::fprintf(stderr, "cannot read %s\n", path.c_str());
    std::exit(1);
  }
  return Bytes(std::istreambuf_iterator<char>(f), {});
}

template <class Msg>
Bytes encode(const Msg& msg) {
  Bytes b(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

Bytes concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// A small picture with edges and colour, as a camera would see a ball in front of a wall.
cv::Mat picture(int width, int height, bool gray) {
  cv::Mat bgr(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      bgr.at<cv::Vec3b>(y, x) = {static_cast<uchar>(4 * x), static_cast<uchar>(6 * y), 90};
    }
  }
  cv::circle(bgr, {width / 2, height / 2}, height / 3, {30, 30, 210}, cv::FILLED);
  if (!gray) return bgr;
  cv::Mat g;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}

Bytes jpeg(const cv::Mat& image, std::vector<int> params = {cv::IMWRITE_JPEG_QUALITY, 90}) {
  Bytes b;
  cv::imencode(".jpg", image, b, params);
  return b;
}

void messages() {
  using namespace ptzstereo;
  const ptz::PtzPose left{0.2, -0.05, 2.0}, right{0.18, -0.05, 2.0};
  const int64_t t = 1'700'000'000'000'000;
  for (int8_t enc : {image_t::ENCODING_RAW, image_t::ENCODING_JPEG}) {
    const std::string e = enc == image_t::ENCODING_RAW ? "raw" : "jpeg";
    stereo_frame_t f = ptz::makeStereoFrame(t, 7, picture(32, 24, false), left,
                                            picture(32, 24, false), right, enc, 90);
    f.publish_utime = t + 12'000;
    write("fuzz_stereo_frame", "bgr_" + e, encode(f));
    f = ptz::makeStereoFrame(t, 8, picture(16, 12, true), left, picture(16, 12, true), right, enc,
                             90);
    write("fuzz_stereo_frame", "gray_" + e, encode(f));
    // The issue's frame that killed ptz-detect: the right image says GRAY8 beside a BGR left.
    f = ptz::makeStereoFrame(t, 9, picture(16, 12, false), left, picture(16, 12, false), right, enc,
                             90);
    f.right.pixel_format = image_t::PIXEL_GRAY8;
    write("fuzz_stereo_frame", "right_says_gray_" + e, encode(f));
  }
  stereo_frame_t rgb = ptz::makeStereoFrame(t, 10, picture(8, 6, false), left, picture(8, 6, false),
                                            right, image_t::ENCODING_RAW, 90);
  rgb.left.pixel_format = rgb.right.pixel_format = image_t::PIXEL_RGB8;
  rgb.left.row_stride = rgb.right.row_stride = 8 * 3 + 4;  // padded rows
  rgb.left.data.resize(static_cast<size_t>(rgb.left.row_stride * 6));
  rgb.right.data = rgb.left.data;
  rgb.left.data_size = rgb.right.data_size = static_cast<int32_t>(rgb.left.data.size());
  write("fuzz_stereo_frame", "rgb_padded_rows", encode(rgb));
  // The issue's 2 GB data_size: the count kept, the data cut to what a datagram holds.
  Bytes huge = encode(rgb);
  const size_t data_size_at = 8 + 3 * 8 + 3 * 4 + 2 + 3 * 8;
  for (int i = 0; i < 4; ++i) huge[data_size_at + static_cast<size_t>(i)] = i == 0 ? 0x7F : 0xFF;
  write("fuzz_stereo_frame", "data_size_2g", huge);

  object_detections_t d{};
  d.utime = t;
  d.publish_utime = t + 20'000;
  d.frame_seq = 7;
  detection_2d_t det{"red_ball", 320.5, 240.25, 1200, 300, 220, 41, 40, 0.02, 0};
  d.left = {det, det};
  d.left[1].class_name = "blue_ball";
  d.left[1].match_index = -1;
  d.right = {det};
  d.num_left = 2;
  d.num_right = 1;
  write("fuzz_object_detections", "two_left_one_right", encode(d));
  d.left.clear();
  d.right.clear();
  d.num_left = d.num_right = 0;
  write("fuzz_object_detections", "none", encode(d));

  object_pose_t p{};
  p.utime = t;
  p.publish_utime = t + 21'000;
  p.frame_seq = 7;
  p.left_ptz = {0.2, -0.05, 2.0};
  p.right_ptz = {0.18, -0.05, 2.0};
  p.target_index = 0;
  object_3d_t o{};
  o.class_name = "red_ball";
  o.position_m[0] = 0.1;
  o.position_m[1] = -0.2;
  o.position_m[2] = 3.0;
  for (int i = 0; i < 9; i += 4) o.covariance_m2[i] = 1e-4;
  o.radius_m = 0.1;
  p.objects = {o, o};
  p.objects[1].class_name = "green_box";
  p.objects[1].has_orientation = true;
  p.objects[1].orientation_wxyz[0] = std::cos(0.25);
  p.objects[1].orientation_wxyz[2] = std::sin(0.25);
  p.objects[1].orientation_covariance_rad2[4] = 0.001;
  p.num_objects = 2;
  write("fuzz_object_pose", "two_objects", encode(p));
  // The issue's 10 000 000 objects in a small message.
  Bytes many = encode(p);
  const size_t count_at = 8 + 3 * 8 + 2 * 3 * 8 + 4;
  const int32_t n = 10'000'000;
  for (int i = 0; i < 4; ++i)
    many[count_at + static_cast<size_t>(i)] = static_cast<uint8_t>(n >> (24 - 8 * i));
  write("fuzz_object_pose", "num_objects_10m", many);

  object_tracks_t tracks{};
  tracks.utime = t;
  tracks.publish_utime = t + 21'500;
  tracks.frame_seq = 7;
  tracks.left_ptz = p.left_ptz;
  tracks.right_ptz = p.right_ptz;
  tracks.target_id = 3;
  tracks.target_reason = "locked on track 3 (red_ball) by class";
  object_track_t track{};
  track.id = 3;
  track.class_name = "red_ball";
  track.state = object_track_t::STATE_CONFIRMED;
  for (int i = 0; i < 3; ++i) {
    track.position_m[i] = o.position_m[i];
    track.position_covariance_m2[4 * i] = 1e-4;
    track.velocity_covariance_m2_s2[4 * i] = 1e-2;
  }
  track.velocity_m_s[0] = 0.4;
  track.radius_m = 0.1;
  track.age_s = 5.2;
  track.since_update_s = 0;
  track.object_index = 0;
  tracks.tracks = {track, track};
  object_track_t& box = tracks.tracks[1];
  box.id = 5;
  box.class_name = "green_box";
  box.state = object_track_t::STATE_COASTING;
  box.since_update_s = 0.1;
  box.object_index = -1;
  box.untrusted_updates = 2;
  box.has_orientation = true;
  box.orientation_wxyz[0] = 1;
  for (int i = 0; i < 9; i += 4) box.orientation_covariance_rad2[i] = 0.01;
  tracks.num_tracks = 2;
  write("fuzz_object_tracks", "two_tracks", encode(tracks));
  // 10 000 000 tracks in a small message, as the poses above.
  Bytes many_tracks = encode(tracks);
  const size_t tracks_count_at = 8 + 3 * 8 + 2 * 3 * 8 + 8 + 4 + tracks.target_reason.size() + 1;
  for (int i = 0; i < 4; ++i)
    many_tracks[tracks_count_at + static_cast<size_t>(i)] = static_cast<uint8_t>(n >> (24 - 8 * i));
  write("fuzz_object_tracks", "num_tracks_10m", many_tracks);

  target_select_t select{};
  select.utime = select.publish_utime = t;
  select.mode = target_select_t::MODE_CLASS;
  select.class_name = "green_box";
  select.track_id = -1;
  select.frame_seq = -1;
  write("fuzz_target_select", "by_class", encode(select));
  select.mode = target_select_t::MODE_TRACK_ID;
  select.class_name = "";
  select.track_id = 5;
  write("fuzz_target_select", "by_track_id", encode(select));
  select.mode = target_select_t::MODE_IMAGE_POINT;
  select.track_id = -1;
  select.camera = target_select_t::CAMERA_RIGHT;
  select.x_px = 412.5;
  select.y_px = 230.25;
  select.frame_seq = 7;
  write("fuzz_target_select", "by_image_point", encode(select));

  control_state_t cs{};
  cs.utime = t;
  cs.publish_utime = t + 22'000;
  cs.frame_seq = 7;
  cs.state = control_state_t::STATE_TRACKING;
  cs.target_id = 3;
  cs.search_waypoint = -1;
  cs.reason = "tracking";
  write("fuzz_control_state", "tracking", encode(cs));
  cs.state = control_state_t::STATE_SEARCHING;
  cs.target_id = -1;
  cs.since_target_s = 1.5;
  cs.search_waypoint = 2;
  cs.search_waypoints = 8;
  cs.reason = "no target: searching, waypoint 3 of 8";
  write("fuzz_control_state", "searching", encode(cs));

  point_cloud_t c{};
  c.utime = t;
  c.frame_seq = 7;
  c.frame_id = "left_camera";
  c.width = 4;
  c.height = 1;
  c.is_dense = 1;
  for (const char* name : {"x", "y", "z"}) {
    point_field_t field{};
    field.name = name;
    field.offset = static_cast<int32_t>(4 * c.fields.size());
    field.datatype = point_field_t::FLOAT32;
    field.count = 1;
    c.fields.push_back(field);
  }
  c.num_fields = 3;
  c.point_step = 12;
  c.row_step = 48;
  c.data.assign(48, 0);
  for (size_t i = 0; i < 48; i += 4) c.data[i + 3] = 0x3F;
  c.data_size = 48;
  write("fuzz_point_cloud", "four_points", encode(c));

  process_status_t s{};
  s.utime = t;
  s.process = "ptz-detect";
  s.hostname = "rig";
  s.pid = 4242;
  s.uptime_s = 12.5;
  s.state = process_status_t::STATE_WARN;
  s.message = "STEREO_FRAME absent for 1.2 s";
  channel_status_t ch{"STEREO_FRAME", channel_status_t::DIRECTION_IN, 29.8, 600, 2, 3.1, 7.9};
  s.channels = {ch, ch};
  s.channels[1].channel = "OBJECT_POSE";
  s.channels[1].direction = channel_status_t::DIRECTION_OUT;
  s.num_channels = 2;
  s.counters = {{"frames_processed", 598}, {"dropped_undecodable", 1}, {"seq_gap", 1}};
  s.num_counters = 3;
  write("fuzz_process_status", "detect_warn", encode(s));

  ptz_setpoint_t sp{};
  sp.utime = t;
  sp.publish_utime = t + 22'000;
  sp.frame_seq = 7;
  sp.left = {0.21, -0.04, 2.1};
  sp.right = {0.19, -0.04, 2.1};
  write("fuzz_ptz_setpoint", "tracking", encode(sp));
  sp.publish_utime = std::numeric_limits<int64_t>::min();  // the issue's overflow
  sp.left.pan_rad = std::nan("");
  write("fuzz_ptz_setpoint", "int64_min_and_nan", encode(sp));

  ptz_state_t st{};
  st.utime = t;
  st.publish_utime = t + 100;
  st.left = {0.2, -0.05, 2.0, 0.01, 0.0, 0.0, 0};
  st.right = {0.18, -0.05, 2.0, 0.01, 0.0, 0.0, 1};
  st.setpoint_utime = t - 10'000;
  write("fuzz_ptz_state", "moving", encode(st));

  sim_truth_t tr{};
  tr.utime = t;
  tr.frame_seq = 7;
  tr.left_head = st.left;
  tr.right_head = st.right;
  tr.left_camera.width = tr.right_camera.width = 640;
  tr.left_camera.height = tr.right_camera.height = 480;
  tr.left_camera.fx_px = tr.left_camera.fy_px = 1000;
  tr.left_camera.rotation_head_camera[0] = tr.left_camera.rotation_head_camera[4] = 1;
  tr.left_camera.rotation_head_camera[8] = 1;
  tr.right_camera = tr.left_camera;
  sim_object_truth_t ot{"ball",      "red_ball", "sphere",     {0.1, 0.2, 3},
                        {0.3, 0, 0}, 0.1,        {1, 0, 0, 0}, {1, 0.5}};
  tr.objects = {ot, ot};
  tr.objects[1].name = "box";
  tr.objects[1].shape = "box";
  tr.objects[1].orientation_wxyz[0] = std::cos(0.25);
  tr.objects[1].orientation_wxyz[2] = std::sin(0.25);
  tr.num_objects = 2;
  write("fuzz_sim_truth", "two_objects", encode(tr));
}

// Width and height, 2 bytes each big-endian, then data: the JPEG targets' input.
Bytes sizedPrefix(int width, int height, const Bytes& data) {
  Bytes b = {static_cast<uint8_t>(width >> 8), static_cast<uint8_t>(width),
             static_cast<uint8_t>(height >> 8), static_cast<uint8_t>(height)};
  b.insert(b.end(), data.begin(), data.end());
  return b;
}

void jpegs() {
  auto with = [](int8_t pixel_format, int width, int height, const Bytes& data) {
    Bytes b = {static_cast<uint8_t>(pixel_format)};
    const Bytes sized = sizedPrefix(width, height, data);
    b.insert(b.end(), sized.begin(), sized.end());
    return b;
  };
  using ptzstereo::image_t;
  write("fuzz_jpeg", "bgr_q90", with(image_t::PIXEL_BGR8, 32, 24, jpeg(picture(32, 24, false))));
  write("fuzz_jpeg", "rgb_q50",
        with(image_t::PIXEL_RGB8, 24, 16,
             jpeg(picture(24, 16, false), {cv::IMWRITE_JPEG_QUALITY, 50})));
  write("fuzz_jpeg", "gray", with(image_t::PIXEL_GRAY8, 16, 16, jpeg(picture(16, 16, true))));
  write("fuzz_jpeg", "progressive",
        with(image_t::PIXEL_BGR8, 32, 24,
             jpeg(picture(32, 24, false), {cv::IMWRITE_JPEG_PROGRESSIVE, 1})));
  write("fuzz_jpeg", "optimized_restarts",
        with(image_t::PIXEL_BGR8, 40, 8,
             jpeg(picture(40, 8, false),
                  {cv::IMWRITE_JPEG_OPTIMIZE, 1, cv::IMWRITE_JPEG_RST_INTERVAL, 1})));
  // As ptz-sim and ptz-camera send them (encodeImage: restart markers splitting every MCU row),
  // tall enough that a part's rows are decoded from restart segments alone; wide enough for three
  // tiles of 8 MCUs a row; and every second row.
  write("fuzz_jpeg", "row_restarts",
        with(image_t::PIXEL_BGR8, 48, 96,
             ptz::encodeImage(picture(48, 96, false), image_t::ENCODING_JPEG, 90).data));
  write("fuzz_jpeg", "tiled_restarts",
        with(image_t::PIXEL_BGR8, 384, 96,
             ptz::encodeImage(picture(384, 96, false), image_t::ENCODING_JPEG, 90).data));
  write("fuzz_jpeg", "restarts_every_two_rows",
        with(image_t::PIXEL_BGR8, 40, 112,
             jpeg(picture(40, 112, false),
                  {cv::IMWRITE_JPEG_QUALITY, 80, cv::IMWRITE_JPEG_RST_INTERVAL, 6})));
  // The issue's JPEG whose header says more than the message.
  write("fuzz_jpeg", "header_larger_than_message",
        with(image_t::PIXEL_BGR8, 16, 12, jpeg(picture(32, 24, false))));
}

// Recorded files as ptz-camera reads them: the published size (2 + 2 bytes), then the file.
void recorded_jpegs() {
  const auto sized = sizedPrefix;
  using ptzstereo::image_t;
  const Bytes recorded = ptz::encodeImage(picture(48, 32, false), image_t::ENCODING_JPEG, 90).data;
  write("fuzz_pass_through_jpeg", "recorded", sized(48, 32, recorded));
  write("fuzz_pass_through_jpeg", "any_size", sized(0, 0, jpeg(picture(40, 24, false))));
  Bytes padded = recorded;
  padded.insert(padded.end(), 8, 0);  // some cameras pad after the end marker
  write("fuzz_pass_through_jpeg", "padded", sized(48, 32, padded));
  write("fuzz_pass_through_jpeg", "other_size", sized(24, 16, recorded));
  write("fuzz_pass_through_jpeg", "grey", sized(16, 16, jpeg(picture(16, 16, true))));
  write("fuzz_pass_through_jpeg", "progressive",
        sized(32, 24, jpeg(picture(32, 24, false), {cv::IMWRITE_JPEG_PROGRESSIVE, 1})));
  write("fuzz_pass_through_jpeg", "cut_short",
        sized(48, 32, Bytes(recorded.begin(), recorded.begin() + recorded.size() / 2)));
  // An APP1 "Exif" segment after the start marker (its orientation would turn the image).
  Bytes exif(recorded.begin(), recorded.begin() + 2);
  const Bytes app1 = {0xFF, 0xE1, 0x00, 0x10, 'E',  'x', 'i', 'f', 0,
                      0,    'M',  'M',  0,    0x2A, 0,   0,   0,   0x08};
  exif.insert(exif.end(), app1.begin(), app1.end());
  exif.insert(exif.end(), recorded.begin() + 2, recorded.end());
  write("fuzz_pass_through_jpeg", "exif", sized(48, 32, exif));
}

void visca_bytes() {
  for (int nibbles : {4, 5}) {
    ptz::driver::ViscaModel m;
    m.pan_nibbles = nibbles;
    m.pan_units_per_rad = m.tilt_units_per_rad = (nibbles == 5 ? 51.2 : 13.335) * 180 / M_PI;
    m.pan_min_rad = -3;
    m.pan_max_rad = 3;
    m.tilt_min_rad = -0.5;
    m.tilt_max_rad = 1.5;
    m.zoom.positions = {0, 16384};
    m.zoom.ratios = {1, 20};
    const ptz::driver::ViscaCameraEmulator camera(m, 1);
    const ptz::PtzPose now{-0.7, 0.3, 4.0};
    const std::vector<Bytes> commands = {
        visca::panTiltAbsolute(1, 24, 20, m.panUnits(-0.7), m.tiltUnits(0.3), nibbles),
        visca::panTiltStop(1, 24, 20),
        visca::zoomDirect(1, m.zoomPosition(4.0)),
        visca::zoomStop(1),
        visca::panTiltPositionInquiry(1),
        visca::zoomPositionInquiry(1),
        {0x81, 0x01, 0x7E, 0xFF}};  // a command the camera does not know
    const std::string n = std::to_string(nibbles);
    Bytes stream;
    for (size_t i = 0; i < commands.size(); ++i) {
      ptz::driver::ViscaTarget target;
      Bytes replies;
      for (const Bytes& r : camera.handle(commands[i], now, &target)) {
        replies.insert(replies.end(), r.begin(), r.end());
      }
      const std::string name = n + "nibbles_" + std::to_string(i);
      // What the driver reads (one byte: piece size), and what the camera reads.
      write("fuzz_visca", "serial_" + name, concat({{static_cast<uint8_t>(i)}, replies}));
      write("fuzz_visca", "ip_" + name,
            concat({{0x07}, visca_ip::wrap(visca_ip::kReply, static_cast<uint32_t>(i), replies)}));
      const uint8_t mode = nibbles == 5 ? 1 : 0;
      write("fuzz_visca_camera", "serial_" + name, concat({{mode}, commands[i]}));
      const uint16_t type = commands[i][1] == 0x09 ? visca_ip::kInquiry : visca_ip::kCommand;
      write("fuzz_visca_camera", "ip_" + name,
            concat({{mode}, visca_ip::wrap(type, static_cast<uint32_t>(100 + i), commands[i])}));
      stream.insert(stream.end(), replies.begin(), replies.end());
    }
    // A serial line: replies back to back, noise in between, the broadcasts coming round.
    write("fuzz_visca", "serial_stream_" + n,
          concat({{0x03},
                  {0x00, 0x13},
                  stream,
                  visca::addressSet(),
                  {0x88, 0x30, 0x03, 0xFF},
                  visca::ifClear(),
                  {0xFF, 0xFF}}));
  }
  write("fuzz_visca", "ip_control_reply",
        concat({{0x01}, visca_ip::wrap(visca_ip::kControlReply, 0, {0x01})}));
  write("fuzz_visca_camera", "chain_address_set_and_clear",
        concat({{0x00}, visca::addressSet(), visca::ifClear(), visca::panTiltPositionInquiry(2)}));
  write("fuzz_visca_camera", "ip_reset", concat({{0x01}, visca_ip::resetSequence(5)}));
}

void pelco_bytes() {
  write("fuzz_pelco_d", "pan_reply", concat({{0x06}, pelco_d::frame(1, 0, 0x59, 0x46, 0x50)}));
  write("fuzz_pelco_d", "tilt_zoom_replies",
        concat({{0x02},
                pelco_d::frame(1, 0, 0x5B, 0x88, 0xB8),
                pelco_d::frame(2, 0, 0x5D, 0, 0x80),
                pelco_d::frame(1, 0, 0, 0, 0)}));
  write("fuzz_pelco_d", "noise_and_bad_checksum",
        concat({{0x00},
                {0x12, 0xFF, 0x01, 0x00},
                {0xFF, 0x01, 0x00, 0x59, 0x10, 0x00, 0x00},
                pelco_d::frame(1, 0, 0x59, 0x10, 0x00)}));
  write("fuzz_pelco_d", "commands",
        concat({{0x1F},
                pelco_d::setPanPosition(1, 12000),
                pelco_d::setTiltPosition(1, 35000),
                pelco_d::setZoomPosition(2, 30000),
                pelco_d::queryPan(1),
                pelco_d::queryTilt(2),
                pelco_d::queryZoom(1),
                pelco_d::panTilt(1, 20, -10),
                pelco_d::stop(2)}));
}

void files(const std::string& source) {
  const std::string config = source + "/config/";
  for (const char* f : {"sim_default.yaml", "sim_paper.yaml", "detect_default.yaml",
                        "control_paper.yaml", "driver_visca_ip.yaml"}) {
    write("fuzz_config", f, readFile(config + f));
  }
  for (const char* f : {"sim_default.yaml", "sim_paper.yaml"}) {
    write("fuzz_scene", f, readFile(config + f));
  }
  write("fuzz_config", "every_parameter.yaml",
        "%YAML:1.0\n---\nlcm_url: \"memq://\"\nchannel_prefix: \"SIM_\"\nstatus_period_s: 1.0\n"
        "dead_time_s: 0.1\nplant_step_s: 0.001\npan_gain: 1.7\npan_time_constant_s: 0.24\n"
        "pan_min: -2.9\npan_max: 2.9\npan_max_rate: 5.2\ntilt_min: -0.5\ntilt_max: 1.5\n"
        "zoom_min: 1\nzoom_max: 10\nencoding: \"jpeg\"\njpeg_quality: 80\n"
        "setpoint_max_age_ms: 300\nsetpoint_future_tolerance_ms: 50\nrig_file: \"\"\n"
        "frames: 100\nframe_rate_hz: 60.0\nmin_range_m: 0.3\nmax_range_m: 12\nshow: true\n"
        "objects:\n  - { name: \"a\" }\n");
  write("fuzz_config", "every_parameter.json",
        "{\n  \"frames\": 3,\n  \"frame_rate_hz\": 15.5,\n  \"show\": \"off\",\n"
        "  \"encoding\": \"raw\",\n  \"pan_min\": -1,\n  \"pan_max\": 1\n}\n");
  write("fuzz_config", "every_parameter.xml",
        "<?xml version=\"1.0\"?>\n<opencv_storage>\n<frames>3</frames>\n"
        "<frame_rate_hz>15.5</frame_rate_hz>\n<encoding>raw</encoding>\n</opencv_storage>\n");
  write(
      "fuzz_scene", "every_shape_and_board.yaml",
      "%YAML:1.0\n---\nscene:\n  backdrop_distance_m: 6.0\n  floor_height_m: 1.2\n"
      "  texture_m_per_texel: 0.02\n  texture_seed: 3\nobjects:\n"
      "  - { name: \"b\", class: \"green_box\", shape: \"box\", half_extents_m: [0.1, 0.2, 0.3],\n"
      "      yaw_rad: 0.3, color_bgr: [0, 200, 0], textured: 1, trajectory: \"circle\",\n"
      "      centre_m: [0, 0, 3], amplitude_m: [1, 0, 1], period_s: 10, phase_rad: 1 }\n"
      "  - { name: \"w\", class: \"red_ball\", shape: \"sphere\", radius_m: 0.1,\n"
      "      color_bgr: [0, 0, 200], trajectory: \"random_walk\", seed: 5,\n"
      "      amplitude_m: [0.5, 0.1, 0.5] }\n"
      "  - { name: \"l\", class: \"red_ball\", shape: \"sphere\", radius_m: 0.2,\n"
      "      color_bgr: [0, 0, 200], trajectory: \"line\", amplitude_m: [0.5, 0, 0] }\n"
      "chessboard:\n  inner_cols: 9\n  inner_rows: 6\n  square_m: 0.05\n"
      "  centre_m: [0, 0, 2]\n  rotation_vector: [0.1, 0.2, 0]\n");
  for (const char* f : {"sony_evi_d70.yaml", "sony_srg300.yaml"}) {
    write("fuzz_visca_model", f, readFile(config + "visca/" + f));
  }
  write("fuzz_pelco_model", "generic.yaml", readFile(config + "pelco_d/generic.yaml"));

  // Rig files as ptz-calibrate writes them (through a scratch file: save() takes a path).
  const std::string scratch = g_out + "/.rig-scratch.yaml";
  ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  rig.save(scratch);
  write("fuzz_rig", "default.yaml", readFile(scratch));
  rig.left.zoom_table.resize(1);
  rig.right.zoom_table.resize(1);
  rig.save(scratch, [](cv::FileStorage& fs) {
    fs << "calibration"
       << "{"
       << "rms_px" << 0.31 << "pairs" << 13 << "}";
  });
  write("fuzz_rig", "one_zoom_with_report.yaml", readFile(scratch));
  std::remove(scratch.c_str());
}

void logs() {
  using namespace ptzstereo;
  const std::string scratch = g_out + "/.log-scratch.lcmlog";
  auto event = [](lcm::LogFile& log, int64_t n, const char* channel, const Bytes& data) {
    lcm::LogEvent ev{};
    ev.eventnum = n;
    ev.timestamp = 1'700'000'000'000'000 + n * 33'333;
    ev.channel = channel;
    ev.datalen = static_cast<int32_t>(data.size());
    ev.data = const_cast<uint8_t*>(data.data());
    log.writeEvent(&ev);
  };
  ptz_state_t st{};
  st.left.zoom = st.right.zoom = 1;
  ptz_setpoint_t sp{};
  sp.left.zoom = sp.right.zoom = 1.5;
  process_status_t s{};
  s.process = "ptz-sim";
  s.hostname = "h";
  s.message = "ok";
  stereo_frame_t f = ptz::makeStereoFrame(1, 1, picture(8, 6, false), {}, picture(8, 6, false), {},
                                          image_t::ENCODING_JPEG, 50);
  {
    lcm::LogFile log(scratch, "w");
    event(log, 0, "PTZ_STATE", encode(st));
    event(log, 1, "STEREO_FRAME", encode(f));
    event(log, 2, "PTZ_SETPOINT", encode(sp));
    event(log, 3, "PROCESS_STATUS_PTZ_SIM", encode(s));
  }
  const Bytes whole = readFile(scratch);
  write("fuzz_log_reader", "four_events", whole);
  write("fuzz_log_reader", "truncated", Bytes(whole.begin(), whole.end() - 9));
  Bytes damaged = whole;
  damaged.insert(damaged.begin() + 40, {0xDE, 0xAD, 0xBE, 0xEF, 0xED, 0xA1});
  write("fuzz_log_reader", "garbage_between_events", damaged);
  std::remove(scratch.c_str());
}

// ptz-foxglove-bridge's client messages (NUL between messages) and the converter's runs.
void foxglove() {
  const std::string ops[] = {
      R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":3},{"id":2,"channelId":5}]})",
      R"({"op":"unsubscribe","subscriptionIds":[1]})",
      R"({"op":"subscribe","subscriptions":[{"id":4,"channelId":99},{"id":"x","channelId":-1}]})",
      R"({"op":"advertise","channels":[]})",
      R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":2,"extra":"ÿ"}]})",
      "[1,2,3]",
      "{\"op\":\"\xff\xfe\"}",
  };
  std::string all;
  for (const std::string& op : ops) all += op + std::string(1, '\0');
  write("fuzz_foxglove_client", "every_op", all);
  write("fuzz_foxglove_client", "subscribe_then_unsubscribe", ops[0] + '\0' + ops[1]);
  write("fuzz_foxglove_client", "binary_publish", std::string("\x01\x07\0\0\0abc", 8));
  const Bytes records = g_convert_records;
  for (uint8_t options : {0, 1 | 2 | 4, 8}) {
    write("fuzz_foxglove_convert", "every_message_options_" + std::to_string(options),
          concat({{options}, records}));
  }
}

// fuzz_onvif_camera: mode byte (bit 0 cheap, bit 1 password "secret"), then a SOAP request.
void onvif_requests() {
  const auto envelope = [](const std::string& body, const std::string& header = "") {
    return "<s:Envelope xmlns:s=\"http://www.w3.org/2003/05/soap-envelope\"><s:Header>" + header +
           "</s:Header><s:Body>" + body + "</s:Body></s:Envelope>";
  };
  const auto op = [&](const std::string& name, const std::string& ns, const std::string& inner) {
    return envelope("<" + name + " xmlns=\"http://www.onvif.org/" + ns + "\">" + inner + "</" +
                    name + ">");
  };
  const std::string ptz = "ver20/ptz/wsdl", media = "ver10/media/wsdl",
                    device = "ver10/device/wsdl",
                    profile = "<ProfileToken>profile_1</ProfileToken>";
  const std::string tt = " xmlns=\"http://www.onvif.org/ver10/schema\"";
  const auto pan_tilt = [&](const std::string& x, const std::string& y) {
    return "<PanTilt" + tt + " x=\"" + x + "\" y=\"" + y + "\"/>";
  };
  const auto zoom = [&](const std::string& x) { return "<Zoom" + tt + " x=\"" + x + "\"/>"; };
  const std::vector<std::tuple<std::string, uint8_t, std::string>> seeds = {
      {"get_status", 0, op("GetStatus", ptz, profile)},
      {"absolute_move_speed", 0,
       op("AbsoluteMove", ptz,
          profile + "<Position>" + pan_tilt("0.5", "-0.25") + zoom("0.5") + "</Position><Speed>" +
              pan_tilt("0.1", "0.1") + zoom("1") + "</Speed>")},
      {"absolute_move_cheap", 1,
       op("AbsoluteMove", ptz,
          profile + "<Position>" + pan_tilt("-1", "1") + "</Position><Speed>" +
              pan_tilt("0.1", "0.1") + "</Speed>")},
      {"relative_move", 0,
       op("RelativeMove", ptz,
          profile + "<Translation>" + pan_tilt("0.2", "0") + zoom("-0.1") + "</Translation>")},
      {"continuous_move", 0,
       op("ContinuousMove", ptz,
          profile + "<Velocity>" + pan_tilt("-0.5", "0.3") + zoom("1") +
              "</Velocity><Timeout>PT1.5S</Timeout>")},
      {"stop", 0, op("Stop", ptz, profile + "<PanTilt>true</PanTilt><Zoom>false</Zoom>")},
      {"set_preset", 0, op("SetPreset", ptz, profile + "<PresetName>door</PresetName>")},
      {"goto_preset", 0, op("GotoPreset", ptz, profile + "<PresetToken>preset_1</PresetToken>")},
      {"get_presets", 0, op("GetPresets", ptz, profile)},
      {"get_nodes", 0, op("GetNodes", ptz, "")},
      {"get_configuration_options", 0,
       op("GetConfigurationOptions", ptz, "<ConfigurationToken>ptz_config_1</ConfigurationToken>")},
      {"get_profiles", 0, op("GetProfiles", media, "")},
      {"get_stream_uri", 0, op("GetStreamUri", media, profile)},
      {"get_services", 0, op("GetServices", device, "<IncludeCapability>true</IncludeCapability>")},
      {"get_capabilities", 0, op("GetCapabilities", device, "")},
      {"get_device_information", 0, op("GetDeviceInformation", device, "")},
      {"auth_get_time", 2, op("GetSystemDateAndTime", device, "")},
      {"not_xml", 0, "<s:Envelope xmlns:s="},
  };
  for (const auto& [name, mode, request] : seeds) {
    write("fuzz_onvif_camera", name, std::string(1, static_cast<char>(mode)) + request);
  }
  // A valid token for the target's camera clock (1000 s) and password, with a fixed nonce.
  ptz::onvif::UsernameToken token;
  token.user = "admin";
  token.nonce = "0123456789abcdef";
  token.created = ptz::onvif::xsDateTime(1000);
  token.digest = ptz::onvif::passwordDigest(token.nonce, token.created, "secret");
  write("fuzz_onvif_camera", "auth_token",
        std::string(1, '\x02') + envelope("<GetStatus xmlns=\"http://www.onvif.org/" + ptz + "\">" +
                                              profile + "</GetStatus>",
                                          ptz::onvif::securityHeader(token)));
}

// fuzz_disc_split: masks of discs (size bytes, then a bit a pixel): two overlapping, one behind
// another, three in a row, one alone, a square.
void discMasks() {
  struct Disc {
    double x, y, r;
  };
  const auto mask = [](int w, int h, const std::vector<Disc>& discs, bool square) {
    Bytes b = {static_cast<uint8_t>(w - 8), static_cast<uint8_t>(h - 8)};
    b.resize(2 + static_cast<size_t>(w * h + 7) / 8, 0);
    for (int i = 0; i < w * h; ++i) {
      const int x = i % w, y = i / w;
      bool in = square && x >= w / 4 && x < 3 * w / 4 && y >= h / 4 && y < 3 * h / 4;
      for (const Disc& d : discs) in = in || std::hypot(x - d.x, y - d.y) <= d.r;
      if (in) b[2 + static_cast<size_t>(i) / 8] |= static_cast<uint8_t>(1u << (i % 8));
    }
    return b;
  };
  write("fuzz_disc_split", "two_overlapping", mask(64, 48, {{22, 24, 12}, {38, 22, 10}}, false));
  write("fuzz_disc_split", "one_behind", mask(64, 48, {{36, 22, 9}, {30, 24, 13}}, false));
  write("fuzz_disc_split", "three_in_a_row",
        mask(96, 40, {{20, 20, 10}, {36, 21, 10}, {54, 19, 11}}, false));
  write("fuzz_disc_split", "one", mask(40, 40, {{20.3, 19.6, 12}}, false));
  write("fuzz_disc_split", "square", mask(40, 40, {}, true));
}

// fuzz_color_detect: images painted by the target (size, grey, then records of a rectangle or a
// disc and its colour): a red ball before a red-orange poster, one of hue 351 before a poster of
// 10.6 (across the red window's 0), two red balls overlapping, a ball alone.
void colourImages() {
  struct Shape {
    bool disc;
    int x, y, w, h, b, g, r;
  };
  const auto image = [](int w, int h, const std::vector<Shape>& shapes) {
    Bytes bytes = {static_cast<uint8_t>(w - 8), static_cast<uint8_t>(h - 8), 125};
    for (const Shape& s : shapes) {
      for (const int v : {s.disc ? 1 : 0, s.x, s.y, s.w, s.h, s.b, s.g, s.r}) {
        bytes.push_back(static_cast<uint8_t>(v));
      }
    }
    return bytes;
  };
  write("fuzz_color_detect", "ball_before_poster",
        image(128, 96, {{false, 40, 20, 70, 60, 30, 80, 210}, {true, 60, 50, 15, 0, 30, 30, 210}}));
  write("fuzz_color_detect", "ball_before_poster_across_0",
        image(128, 96, {{false, 40, 20, 70, 60, 30, 65, 210}, {true, 60, 50, 15, 0, 60, 30, 210}}));
  write("fuzz_color_detect", "two_balls",
        image(96, 64, {{true, 36, 32, 14, 0, 30, 30, 210}, {true, 58, 30, 12, 0, 30, 30, 210}}));
  write("fuzz_color_detect", "one_ball", image(64, 64, {{true, 31, 33, 12, 0, 200, 60, 40}}));
}

// fuzz_markers: images with tags drawn by the target (its 18-byte header, fuzz_markers.cpp), on a
// picture's pixels of exactly the size it cuts both views from; one of noise alone. The tag's size
// in metres is the one its disparity and pixels give at zoom 1 in the middle of the default rig's
// frames (fx 500 px, baseline 0.3 m, 8.5 px of disparity at infinity, the right view 2 rows
// higher), so that its poses can be accepted.
void markerImages() {
  struct Seed {
    const char* name;
    int width, height;
    int choice;    // 0 libapriltag apriltag_36h11, 1 ArUco aruco_4x4_50, 2 ArUco apriltag_36h11
    int decimate;  // 0: 1, 1: 1.5, 2: 2
    bool second, same_id, bilinear;
    int id, side;
    double x, y, turn_deg;  // the tag's centre as a share of the image (may be beyond), its turn
    int dx, dy;             // the second tag's centre from the first's
    int disparity;
    int drop;         // rows the right view is cut lower
    int noise_bytes;  // > 0: that many bytes of noise for pixels, and no tag
  };
  const Seed seeds[] = {
      {"apriltag_square", 96, 72, 0, 2, false, false, false, 0, 48, 0.65, 0.5, 0, 0, 0, 30, 2, 0},
      {"apriltag_turned_bilinear", 120, 100, 0, 1, false, false, true, 42, 56, 0.45, 0.55, 30, 0, 0,
       24, 2, 0},
      {"apriltag_cut_by_the_edge", 80, 64, 0, 0, false, false, false, 586, 40, 0.9, 0.4, 0, 0, 0,
       20, 1, 0},
      {"aruco_4x4", 96, 64, 1, 0, false, false, false, 7, 40, 0.6, 0.5, 0, 0, 0, 24, 2, 0},
      {"aruco_4x4_twice", 128, 64, 1, 0, true, true, false, 3, 36, 0.3, 0.5, 10, 60, 0, 20, 2, 0},
      {"aruco_apriltag_bundle", 160, 80, 2, 0, true, false, false, 5, 56, 0.3, 0.5, 0, 64, 0, 24, 2,
       0},
      {"noise_no_tag", 160, 160, 0, 1, false, false, false, 0, 8, 0, 0, 0, 0, 0, -4, 0, 37},
  };
  for (const Seed& s : seeds) {
    const int bits = s.choice == 1 ? 4 : 6;
    const double square_px = s.side * (bits + 2.0) / (bits + 4.0);
    const double range_m = 500.0 * 0.3 / std::max(1.0, s.disparity - 8.5);
    const double size_m = square_px * range_m / 500.0;
    const auto byte = [](double v) {
      return static_cast<uint8_t>(std::clamp(v + 0.5, 0.0, 255.0));
    };
    Bytes b = {
        static_cast<uint8_t>(s.width - 8),
        static_cast<uint8_t>(s.height - 8),
        static_cast<uint8_t>(s.choice | s.decimate << 2 | (s.noise_bytes ? 0 : 0x10) |
                             (s.second ? 0x20 : 0) | (s.same_id ? 0x40 : 0) |
                             (s.bilinear ? 0x80 : 0)),
        static_cast<uint8_t>(s.id & 0xFF),
        static_cast<uint8_t>(s.id >> 8),
        static_cast<uint8_t>(s.side - 8),
        byte((s.x * s.width + s.side / 2.0) * 255 / (s.width + s.side)),
        byte((s.y * s.height + s.side / 2.0) * 255 / (s.height + s.side)),
        byte(s.turn_deg * 256 / 360),
        static_cast<uint8_t>(static_cast<int8_t>(s.dx)),
        static_cast<uint8_t>(static_cast<int8_t>(s.dy)),
        static_cast<uint8_t>((s.disparity + 8) | s.drop << 6),
        static_cast<uint8_t>(s.width / 4),
        static_cast<uint8_t>(s.height / 4),
        static_cast<uint8_t>(s.width / 2),
        static_cast<uint8_t>(s.height / 2),
        byte((size_m - 0.02) / 0.004),
        0,
    };
    if (s.noise_bytes > 0) {
      uint32_t x = 12345;
      for (int i = 0; i < s.noise_bytes; ++i) {
        x = x * 1103515245u + 12345u;
        b.push_back(static_cast<uint8_t>(x >> 16));
      }
    } else {
      const cv::Mat g = picture(s.width + std::abs(s.disparity), s.height + s.drop, true);
      for (int y = 0; y < g.rows; ++y) b.insert(b.end(), g.ptr<uchar>(y), g.ptr<uchar>(y) + g.cols);
    }
    write("fuzz_markers", s.name, b);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s SOURCE_DIR CORPUS_DIR\n", argv[0]);
    return 2;
  }
  g_out = argv[2];
  ::mkdir(g_out.c_str(), 0755);
  messages();
  jpegs();
  recorded_jpegs();
  visca_bytes();
  pelco_bytes();
  files(argv[1]);
  logs();
  foxglove();
  onvif_requests();
  discMasks();
  colourImages();
  markerImages();
  return 0;
}
