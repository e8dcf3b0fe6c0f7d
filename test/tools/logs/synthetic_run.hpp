// The messages of a made-up run at exactly 10 Hz, for tests of the run's numbers whose answers
// are known by construction: two cameras looking along +z (500 px focal length, 640x480, no
// distortion) 0.1 m apart, objects placed in the head frame.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"

namespace ptz::test::synthetic {

constexpr int64_t kT0 = 1'700'000'000'000'000;
constexpr int64_t kPeriodUs = 100'000;
constexpr double kFocalPx = 500;
constexpr double kHalfBaselineM = 0.05;

inline int64_t utimeOf(int64_t seq) {
  return kT0 + seq * kPeriodUs;
}

inline ptzstereo::camera_model_t camera(double x_m) {
  ptzstereo::camera_model_t c{};
  c.width = 640;
  c.height = 480;
  c.fx_px = c.fy_px = kFocalPx;
  c.cx_px = 319.5;
  c.cy_px = 239.5;
  c.rotation_head_camera[0] = c.rotation_head_camera[4] = c.rotation_head_camera[8] = 1;
  c.position_head_m[0] = x_m;
  return c;
}

struct Object {
  std::string name, class_name;
  std::array<double, 3> position_m;
  double visible_fraction = 1;  // in both cameras
};

inline ptzstereo::sim_truth_t truth(int64_t seq, const std::vector<Object>& objects) {
  ptzstereo::sim_truth_t t{};
  t.utime = utimeOf(seq);
  t.publish_utime = t.utime;
  t.frame_seq = seq;
  t.left_camera = camera(-kHalfBaselineM);
  t.right_camera = camera(kHalfBaselineM);
  for (const auto& o : objects) {
    ptzstereo::sim_object_truth_t s{};
    s.name = o.name;
    s.class_name = o.class_name;
    s.shape = "sphere";
    for (int i = 0; i < 3; ++i) s.position_m[i] = o.position_m[i];
    s.radius_m = 0.05;
    s.visible_fraction[0] = s.visible_fraction[1] = o.visible_fraction;
    t.objects.push_back(s);
  }
  t.num_objects = static_cast<int32_t>(t.objects.size());
  return t;
}

// A pose without a target.
inline ptzstereo::object_pose_t pose(int64_t seq) {
  ptzstereo::object_pose_t p{};
  p.utime = utimeOf(seq);
  p.publish_utime = p.utime + 20'000;
  p.frame_seq = seq;
  p.target_index = -1;
  return p;
}

// A pose whose target is an object of class_name at estimate_m (after a decoy of another class).
inline ptzstereo::object_pose_t pose(int64_t seq, const std::string& class_name,
                                     const std::array<double, 3>& estimate_m) {
  ptzstereo::object_pose_t p = pose(seq);
  ptzstereo::object_3d_t decoy{}, target{};
  decoy.class_name = "green_box";
  decoy.position_m[2] = 9;
  target.class_name = class_name;
  for (int i = 0; i < 3; ++i) target.position_m[i] = estimate_m[i];
  p.objects = {decoy, target};
  p.num_objects = 2;
  p.target_index = 1;
  return p;
}

inline ptzstereo::stereo_frame_t frame(int64_t seq) {
  ptzstereo::stereo_frame_t f{};
  f.utime = utimeOf(seq);
  f.publish_utime = f.utime + 1'000;
  f.seq = seq;
  return f;
}

inline ptzstereo::control_state_t control(int64_t seq, int8_t state, int64_t target_id = -1) {
  ptzstereo::control_state_t c{};
  c.utime = utimeOf(seq);
  c.publish_utime = c.utime + 25'000;
  c.frame_seq = seq;
  c.state = state;
  c.target_id = target_id;
  c.reason = "test";
  return c;
}

inline ptzstereo::ptz_setpoint_t setpoint(int64_t seq) {
  ptzstereo::ptz_setpoint_t s{};
  s.utime = utimeOf(seq);
  s.publish_utime = s.utime + 25'000;
  s.frame_seq = seq;
  s.left.zoom = s.right.zoom = 1;
  return s;
}

inline ptzstereo::object_tracks_t tracks(int64_t seq, int64_t target_id, int live_tracks) {
  ptzstereo::object_tracks_t m{};
  m.utime = utimeOf(seq);
  m.publish_utime = m.utime + 20'000;
  m.frame_seq = seq;
  m.target_id = target_id;
  m.target_reason = "test";
  for (int i = 0; i < live_tracks; ++i) {
    ptzstereo::object_track_t t{};
    t.id = i + 1;
    t.class_name = "red_ball";
    t.state = ptzstereo::object_track_t::STATE_CONFIRMED;
    t.object_index = -1;
    m.tracks.push_back(t);
  }
  m.num_tracks = live_tracks;
  return m;
}

// Writes messages into an LCM log, each stamped with its own utime (the receive time).
class LogWriter {
 public:
  explicit LogWriter(const std::string& path) : log_(path, "w") {}
  template <typename T>
  void put(const std::string& channel, const T& m) {
    std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
    m.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent ev{};
    ev.timestamp = m.utime;
    ev.channel = channel;
    ev.datalen = static_cast<int32_t>(buf.size());
    ev.data = buf.data();
    log_.writeEvent(&ev);
  }

 private:
  lcm::LogFile log_;
};

// A run of 20 frames with two red balls, ball_b (listed first) at (0.5, 0, 2) and ball_a at
// (0, 0, 2), and a green box beside ball_a, logged with every pose before its truth:
// frames 0-1 never answered; 2-4 poses without a target, searching; 5-11 the target near ball_a
// (1 cm off, track 1), tracking; 12-13 no target, coasting on track 1; 14-19 the target near
// ball_b (2 cm off, track 2), tracking.
struct KnownRun {
  static constexpr int kFrames = 20;
  static constexpr int kWithoutPose = 2, kPosesWithoutTarget = 5, kSwitches = 1;
  static constexpr double kLostS = 0.7, kAcquireS = 0.5, kSearchS = 0.3, kCoastS = 0.2;
  static constexpr int kOnA = 7, kOnB = 6;
  static constexpr double kErrorAM = 0.01, kErrorBM = 0.02;
};

inline void writeKnownRun(const std::string& path) {
  const std::vector<Object> objects = {{"ball_b", "red_ball", {0.5, 0, 2}},
                                       {"box", "green_box", {0.012, 0, 2}},
                                       {"ball_a", "red_ball", {0, 0, 2}}};
  LogWriter log(path);
  for (int64_t seq = 0; seq < KnownRun::kFrames; ++seq) {
    const bool on_a = seq >= 5 && seq <= 11, on_b = seq >= 14;
    if (seq >= 2) {
      log.put("OBJECT_POSE", on_a   ? pose(seq, "red_ball", {0.01, 0, 2})
                             : on_b ? pose(seq, "red_ball", {0.5, 0, 2.02})
                                    : pose(seq));
      log.put("OBJECT_TRACKS", tracks(seq, on_b ? 2 : seq >= 5 ? 1 : -1, seq >= 5 ? 2 : 0));
      const int8_t state = seq < 5                  ? ptzstereo::control_state_t::STATE_SEARCHING
                           : seq == 12 || seq == 13 ? ptzstereo::control_state_t::STATE_COASTING
                                                    : ptzstereo::control_state_t::STATE_TRACKING;
      log.put("CONTROL_STATE", control(seq, state, on_b ? 2 : seq >= 5 ? 1 : -1));
      log.put("PTZ_SETPOINT", setpoint(seq));
    }
    log.put("SIM_TRUTH", truth(seq, objects));
  }
}

}  // namespace ptz::test::synthetic
