// A stereo recording rendered by the simulator, as ptz-camera plays it (issue #18's tests and
// benchmarks): DIR/left/NNNNNN.jpg, DIR/right/NNNNNN.jpg and DIR/left.timestamps,
// DIR/right.timestamps (frame k at start_utime + k / rate_hz), the scenario of a ptz-sim config
// with both cameras at home (no controller), JPEG-encoded by encodeImage as ptz-sim sends them.
// Play it with:
//   ptz-camera --left-source DIR/left --right-source DIR/right --width W --height H
//              --encoding jpeg [--loop true]
#pragma once

#include <opencv2/core.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/rig.hpp"
#include "common/transport/transport.hpp"
#include "sim/simulator.hpp"

namespace ptz::test {

// 2023-11-14 22:13:20 UTC: a fixed past, so that recordings are reproducible to the byte.
constexpr int64_t kSimRecordingStartUtime = 1'700'000'000'000'000;

struct SimRecording {
  int width = 0, height = 0;
  std::vector<int64_t> utimes;  // capture time of frame k, both sides
  int frames_ball_visible = 0;  // frames where "ball" (if any) shows in both images
};

namespace detail {

inline void writeBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("writeSimRecording: cannot write " + path);
}

}  // namespace detail

// The period of the path of sim_config_yaml's object "ball" (s): a recording of that many seconds
// loops without a jump. Throws std::runtime_error when there is no ball.
inline double simBallPeriodS(const std::string& sim_config_yaml) {
  cv::FileStorage fs(sim_config_yaml, cv::FileStorage::READ);
  if (!fs.isOpened()) throw std::runtime_error("simBallPeriodS: cannot read " + sim_config_yaml);
  const sim::Scene scene = sim::Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"],
                                                  "config file '" + sim_config_yaml + "'");
  for (const auto& o : scene.objects) {
    if (o.name == "ball") return o.trajectory.period_s;
  }
  throw std::runtime_error("simBallPeriodS: no object 'ball' in " + sim_config_yaml);
}

// Renders `frames` stereo frames of sim_config_yaml's scene (its scene, objects, chessboard and
// noise_sigma) at image_size ("vga", "720p", "1080p" or WxH) into dir (created if missing).
// Throws std::runtime_error (or ConfigError for the config) on failure.
inline SimRecording writeSimRecording(const std::string& dir, const std::string& sim_config_yaml,
                                      const std::string& image_size, int frames, double rate_hz,
                                      int jpeg_quality,
                                      int64_t start_utime = kSimRecordingStartUtime) {
  SimRecording rec;
  std::string why;
  if (!parseImageSize(image_size, &rec.width, &rec.height, &why)) {
    throw std::runtime_error("writeSimRecording: image_size: " + why);
  }
  cv::FileStorage fs(sim_config_yaml, cv::FileStorage::READ);
  if (!fs.isOpened()) throw std::runtime_error("writeSimRecording: cannot read " + sim_config_yaml);
  const std::string where = "config file '" + sim_config_yaml + "'";
  sim::Scene scene = sim::Scene::fromConfig(fs["scene"], fs["objects"], fs["chessboard"], where);
  int ball = -1;
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    if (scene.objects[i].name == "ball") ball = static_cast<int>(i);
  }
  const double noise = fs["noise_sigma"].empty() ? 2.0 : static_cast<double>(fs["noise_sigma"]);
  sim::Simulator sim(StereoRig::makeDefault().atSize(rec.width, rec.height), std::move(scene),
                     defaultPlantParams(), noise, 1);
  std::filesystem::create_directories(dir + "/left");  // throws naming the path
  std::filesystem::create_directories(dir + "/right");
  std::ofstream ts_left(dir + "/left.timestamps"), ts_right(dir + "/right.timestamps");
  const auto jpeg = [jpeg_quality](const cv::Mat& image) {
    return encodeImage(image, ptzstereo::image_t::ENCODING_JPEG, jpeg_quality).data;
  };
  std::future<void> writing;  // frame k encodes and writes while frame k + 1 renders
  for (int k = 0; k < frames; ++k) {
    sim.advanceTo(k / rate_hz);
    sim::SimFrame f = sim.capture();
    if (ball >= 0 && f.visible_fraction[0][static_cast<size_t>(ball)] > 0 &&
        f.visible_fraction[1][static_cast<size_t>(ball)] > 0) {
      ++rec.frames_ball_visible;
    }
    char name[32];
    std::snprintf(name, sizeof name, "/%06d.jpg", k);
    if (writing.valid()) writing.get();
    writing = std::async(std::launch::async, [=, f = std::move(f)] {
      auto right = std::async(std::launch::async, [&] { return jpeg(f.right); });
      detail::writeBytes(dir + "/left" + name, jpeg(f.left));
      detail::writeBytes(dir + "/right" + name, right.get());
    });
    const int64_t t = start_utime + std::llround(k * 1e6 / rate_hz);
    rec.utimes.push_back(t);
    ts_left << t << "\n";
    ts_right << t << "\n";
  }
  if (writing.valid()) writing.get();
  if (!ts_left || !ts_right) throw std::runtime_error("writeSimRecording: cannot write timestamps");
  return rec;
}

}  // namespace ptz::test
