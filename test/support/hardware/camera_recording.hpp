// Stereo recordings for ptz-camera's tests: the simulator's renderer draws a ball circling at
// 3 m as seen by both cameras at home, each frame's number (8 bits) and side drawn into its top
// left corner as big black/white blocks that survive JPEG; a temporary folder; a listener of
// STEREO_FRAME and ptz-camera's status.
#pragma once

#include <stdlib.h>

#include <lcm/lcm-cpp.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <cstdlib>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/stereo_frame_t.hpp"
#include "sim/render/renderer.hpp"

namespace ptz::test {

constexpr int kCodeBlockPx = 24;  // 9 blocks: the frame number (8 bits) and the side

// frames frames (at most 256) period_s apart; [0] left, [1] right.
inline std::array<std::vector<cv::Mat>, 2> renderCodedPair(int frames, double period_s) {
  ptz::sim::Scene scene;
  ptz::sim::SceneObject ball;
  ball.name = "ball";
  ball.color_bgr = {30, 30, 210};
  ball.trajectory.type = ptz::sim::Trajectory::Type::kCircle;
  ball.trajectory.centre_m = {0.0, 0.0, 3.0};
  ball.trajectory.amplitude_m = {0.5, 0.3, 0.0};
  ball.trajectory.period_s = 2.0;
  scene.objects = {ball};
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ptz::sim::Renderer renderer(scene);
  std::array<std::vector<cv::Mat>, 2> out;
  for (int k = 0; k < frames; ++k) {
    for (int side = 0; side < 2; ++side) {
      cv::Mat img;
      renderer.render(rig.view(static_cast<ptz::Side>(side), {}), k * period_s, &img);
      for (int bit = 0; bit < 9; ++bit) {
        const bool on = bit < 8 ? (k >> bit) & 1 : side == 1;
        cv::rectangle(img, cv::Rect(bit * kCodeBlockPx, 0, kCodeBlockPx, kCodeBlockPx),
                      cv::Scalar::all(on ? 255 : 0), cv::FILLED);
      }
      out[static_cast<size_t>(side)].push_back(img);
    }
  }
  return out;
}

// The frame number and side drawn into an image ({-1, -1} when the blocks are unreadable).
inline std::pair<int, int> readCode(const cv::Mat& img) {
  int code = 0;
  for (int bit = 0; bit < 9; ++bit) {
    const cv::Rect inner(bit * kCodeBlockPx + 6, 6, kCodeBlockPx - 12, kCodeBlockPx - 12);
    const double v = cv::mean(img(inner))[0];
    if (v > 60 && v < 195) return {-1, -1};
    if (v >= 195) code |= 1 << bit;
  }
  return {code & 0xFF, code >> 8};
}

struct TempDir {
  std::string path;
  TempDir() {
    char tmpl[] = "/tmp/ptz_camera_test_XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() { std::system(("rm -rf '" + path + "'").c_str()); }
};

struct CameraListener {
  std::vector<ptzstereo::stereo_frame_t> frames;
  std::map<std::string, int64_t> counters;
  int8_t state = -1;
  std::string message;
  std::vector<std::string> messages;  // every distinct status message, in order
  int64_t statuses = 0, states_in = 0;
  void onFrame(const lcm::ReceiveBuffer*, const std::string&, const ptzstereo::stereo_frame_t* m) {
    frames.push_back(*m);
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&,
                const ptzstereo::process_status_t* m) {
    ++statuses;
    state = m->state;
    message = m->message;
    if (messages.empty() || messages.back() != message) messages.push_back(message);
    for (const auto& c : m->counters) counters[c.name] = c.value;
    for (const auto& ch : m->channels) {
      if (ch.channel == "PTZ_STATE") states_in = ch.messages;
    }
  }
};

}  // namespace ptz::test
