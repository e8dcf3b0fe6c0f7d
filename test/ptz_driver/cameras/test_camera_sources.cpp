// ptz-camera's sources: the kind recognised from the string, timestamps files (bad lines named),
// and real captures through OpenCV: an image folder played by its recorded times (resized, looped),
// a video file timed by its frame rate, a GStreamer pipeline stamped at grab, missing devices.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/stat.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "common/config.hpp"
#include "common/measure.hpp"
#include "ptz_driver/cameras/sources/capture_source.hpp"
#include "ptz_driver/cameras/stereo_camera.hpp"

using namespace ptz::driver;

namespace {

struct TempDir {
  std::string path;
  TempDir() {
    char tmpl[] = "/tmp/ptz_camera_XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() { std::system(("rm -rf '" + path + "'").c_str()); }
};

void writeText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

std::string configError(const std::function<void()>& f) {
  try {
    f();
  } catch (const ptz::ConfigError& e) {
    return e.what();
  }
  return "no ConfigError";
}

// Reads a source until it ends or fails (or max_frames), waiting on the notifier, never longer
// than 10 s; the wall time each frame was taken is recorded too.
struct Played {
  std::vector<CapturedFrame> frames;
  std::vector<int64_t> taken_utime;
  FrameSource::Poll last = FrameSource::Poll::kNothing;
  std::string error;
};
Played play(const SourceSpec& spec, const CaptureOptions& o, size_t max_frames = 1000,
            std::shared_ptr<PlaybackClock> clock = std::make_shared<PlaybackClock>()) {
  auto notifier = std::make_shared<FrameNotifier>();
  auto source = makeCaptureFactory(spec, o, clock, notifier)();
  Played p;
  const int64_t deadline = ptz::wallUtime() + 10'000'000;
  while (ptz::wallUtime() < deadline && p.frames.size() < max_frames) {
    CapturedFrame f;
    const FrameSource::Poll r = source->poll(&f);
    if (r == FrameSource::Poll::kFrame) {
      p.frames.push_back(f);
      p.taken_utime.push_back(ptz::wallUtime());
      continue;
    }
    if (r != FrameSource::Poll::kNothing) {
      p.last = r;
      p.error = source->error();
      break;
    }
    pollfd fd{notifier->fd(), POLLIN, 0};
    ::poll(&fd, 1, 100);
    notifier->drain();
  }
  return p;
}

}  // namespace

TEST(CameraSources, TheKindIsRecognisedFromTheString) {
  TempDir dir;
  EXPECT_EQ(parseSource("0", "left_source").kind, SourceKind::kV4l2);
  EXPECT_EQ(parseSource("12", "left_source").device_index, 12);
  const SourceSpec dev = parseSource("/dev/video2", "left_source");
  EXPECT_EQ(dev.kind, SourceKind::kV4l2);
  EXPECT_EQ(dev.device_index, -1);
  const SourceSpec rtsp = parseSource("rtsp://192.168.0.10:554/stream1", "left_source");
  EXPECT_EQ(rtsp.kind, SourceKind::kRtsp);
  EXPECT_EQ(rtsp.pipeline,
            "rtspsrc location=rtsp://192.168.0.10:554/stream1 latency=0 ! decodebin ! "
            "videoconvert ! appsink drop=true max-buffers=1 sync=false");
  EXPECT_EQ(parseSource("RTSPS://cam/s", "x").kind, SourceKind::kRtsp);
  const SourceSpec gst = parseSource("v4l2src ! videoconvert ! appsink", "x");
  EXPECT_EQ(gst.kind, SourceKind::kGstreamer);
  EXPECT_EQ(gst.pipeline, "v4l2src ! videoconvert ! appsink");
  EXPECT_EQ(parseSource(dir.path, "x").kind, SourceKind::kImageFolder);
  EXPECT_EQ(parseSource("not/yet/there/", "x").kind, SourceKind::kImageFolder);
  EXPECT_EQ(parseSource("left.avi", "x").kind, SourceKind::kVideoFile);
  EXPECT_EQ(parseSource("0.avi", "x").kind, SourceKind::kVideoFile);
  EXPECT_TRUE(parseSource("0", "x").live());
  EXPECT_TRUE(rtsp.live());
  EXPECT_FALSE(parseSource("left.avi", "x").live());
  EXPECT_EQ(configError([] { parseSource("", "right_source"); }),
            "parameter 'right_source' is empty: name a camera or file");
  EXPECT_EQ(defaultTimestampsPath("rec/left.avi"), "rec/left.avi.timestamps");
  EXPECT_EQ(defaultTimestampsPath("rec/frames/"), "rec/frames.timestamps");
}

TEST(CameraSources, TimestampsFilesAreReadAndBadLinesNamed) {
  TempDir dir;
  const std::string good = dir.path + "/good.timestamps";
  writeText(good,
            "# capture times, us\n1700000000000000\n\n  1700000000040000 \n1700000000090000\n");
  EXPECT_EQ(readTimestamps(good),
            (std::vector<int64_t>{1700000000000000, 1700000000040000, 1700000000090000}));
  const std::string bad = dir.path + "/bad.timestamps";
  writeText(bad, "100\n200\n3O0\n400\n");
  EXPECT_EQ(configError([&] { readTimestamps(bad); }),
            "timestamps file '" + bad + "', line 3: '3O0' is not a time in integer microseconds");
  writeText(bad, "100\n200.5\n");
  EXPECT_EQ(configError([&] { readTimestamps(bad); }),
            "timestamps file '" + bad + "', line 2: '200.5' is not a time in integer microseconds");
  writeText(bad, "100\n# a comment\n200\n200\n");
  EXPECT_EQ(configError([&] { readTimestamps(bad); }),
            "timestamps file '" + bad +
                "', line 4: 200 is not after the previous time 200 (times must increase)");
  writeText(bad, "\n# nothing\n");
  EXPECT_EQ(configError([&] { readTimestamps(bad); }),
            "timestamps file '" + bad + "': no times in it");
  EXPECT_EQ(configError([&] { readTimestamps(dir.path + "/none"); }),
            "timestamps file '" + dir.path + "/none': cannot open");
}

TEST(CameraSources, AnImageFolderPlaysItsSortedFilesAtTheirRecordedTimes) {
  TempDir dir;
  const std::string folder = dir.path + "/frames";
  ASSERT_EQ(::mkdir(folder.c_str(), 0755), 0);
  for (int k = 0; k < 4; ++k) {  // names out of creation order; sorted by name
    cv::imwrite(folder + "/img_" + std::to_string(3 - k) + ".png",
                cv::Mat(8, 10, CV_8UC3, cv::Scalar(40.0 * (3 - k), 100, 7)));
  }
  writeText(folder + "/notes.txt", "not an image");
  writeText(defaultTimestampsPath(folder), "1000000\n1010000\n1025000\n1030000\n");
  CaptureOptions o;
  o.width = 20;
  o.height = 16;
  o.timestamps = readTimestamps(defaultTimestampsPath(folder));
  auto clock = std::make_shared<PlaybackClock>();
  const Played p = play(parseSource(folder, "left_source"), o, 1000, clock);
  EXPECT_EQ(p.last, FrameSource::Poll::kEnded);
  EXPECT_EQ(p.error, "");
  ASSERT_EQ(p.frames.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    const CapturedFrame& f = p.frames[static_cast<size_t>(k)];
    EXPECT_EQ(f.capture_utime, o.timestamps[static_cast<size_t>(k)]);
    EXPECT_EQ(f.index, k);
    EXPECT_TRUE(f.resized);
    EXPECT_EQ(f.image.size(), cv::Size(20, 16));
    EXPECT_EQ(f.image.at<cv::Vec3b>(5, 5), cv::Vec3b(static_cast<uint8_t>(40 * k), 100, 7));
    // Played in real time: never before its recorded time relative to the first.
    EXPECT_GE(p.taken_utime[static_cast<size_t>(k)], clock->dueUtime(f.capture_utime));
  }
  // Fewer times than images: it ends with the times, and says so.
  o.timestamps.pop_back();
  const Played q = play(parseSource(folder, "left_source"), o);
  EXPECT_EQ(q.frames.size(), 3u);
  EXPECT_EQ(q.last, FrameSource::Poll::kEnded);
  EXPECT_EQ(q.error, "its timestamps file ends after 3 times");
}

TEST(CameraSources, ALoopedFolderContinuesItsTimesOneIntervalAfterTheLast) {
  TempDir dir;
  const std::string folder = dir.path + "/frames";
  ASSERT_EQ(::mkdir(folder.c_str(), 0755), 0);
  for (int k = 0; k < 2; ++k)
    cv::imwrite(folder + "/" + std::to_string(k) + ".png", cv::Mat(4, 4, CV_8UC3));
  CaptureOptions o;
  o.loop = true;
  o.timestamps = {1'000'000, 1'010'000};
  const Played p = play(parseSource(folder, "x"), o, 5);
  ASSERT_EQ(p.frames.size(), 5u);
  for (int k = 0; k < 5; ++k)
    EXPECT_EQ(p.frames[static_cast<size_t>(k)].capture_utime, 1'000'000 + k * 10'000);
}

TEST(CameraSources, ARecordingWithAGapLongerThanTheSourceTimeoutPlaysThroughWithoutReopening) {
  // Left: 3 frames, 3 s without any, 3 more; right: 25 Hz throughout. Real time (~3.2 s).
  TempDir dir;
  std::array<std::vector<int64_t>, 2> times;
  for (int k = 0; k < 3; ++k) times[0].push_back(1'000'000 + k * 40'000);
  for (int k = 0; k < 3; ++k) times[0].push_back(4'080'000 + k * 40'000);
  for (int k = 0; k <= 80; ++k) times[1].push_back(1'001'000 + k * 40'000);
  CameraConfig c;
  for (size_t s = 0; s < 2; ++s) {
    const std::string folder = dir.path + (s == 0 ? "/left" : "/right");
    ASSERT_EQ(::mkdir(folder.c_str(), 0755), 0);
    std::string text;
    for (size_t k = 0; k < times[s].size(); ++k) {
      char name[32];
      std::snprintf(name, sizeof name, "/%03zu.png", k);
      cv::imwrite(folder + name, cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(0)));
      text += std::to_string(times[s][k]) + "\n";
    }
    writeText(defaultTimestampsPath(folder), text);
    c.source[s] = parseSource(folder, "source");
    c.capture[s].timestamps = readTimestamps(defaultTimestampsPath(folder));
  }
  c.supervisor = {2.0, 5.0, 0.5, 8.0};  // the gap is longer than source_timeout_s
  c.max_rate_hz = 0;
  auto clock = std::make_shared<PlaybackClock>();
  auto notifier = std::make_shared<FrameNotifier>();
  StereoCamera camera(c, {makeCaptureFactory(c.source[0], c.capture[0], clock, notifier),
                          makeCaptureFactory(c.source[1], c.capture[1], clock, notifier)});
  std::vector<StampedPair> pairs;
  const int64_t deadline = ptz::wallUtime() + 15'000'000;
  while (!camera.finished() && ptz::wallUtime() < deadline) {
    for (auto& p : camera.step(ptz::wallUtime())) pairs.push_back(std::move(p));
    pollfd fd{notifier->fd(), POLLIN, 0};
    ::poll(&fd, 1, 50);
    notifier->drain();
  }
  ASSERT_TRUE(camera.finished());
  const auto counters = camera.counters();
  EXPECT_EQ(counters.at("reconnects_left"), 0) << "the gap was taken for a silent source";
  EXPECT_EQ(counters.at("unmatched_left"), 0);
  EXPECT_EQ(counters.at("frames_left"), 6);
  ASSERT_EQ(pairs.size(), 6u);
  for (size_t k = 0; k < 6; ++k) EXPECT_EQ(pairs[k].left.capture_utime, times[0][k]);
}

TEST(CameraSources, AVideoWithoutTimestampsIsTimedByItsFrameRate) {
  TempDir dir;
  const std::string video = dir.path + "/v.avi";
  cv::VideoWriter w(video, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0, cv::Size(64, 48));
  ASSERT_TRUE(w.isOpened());
  for (int k = 0; k < 6; ++k) w.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar(k * 40, 0, 0)));
  w.release();
  CaptureOptions o;  // keeps the size
  const Played p = play(parseSource(video, "x"), o);
  EXPECT_EQ(p.last, FrameSource::Poll::kEnded);
  ASSERT_EQ(p.frames.size(), 6u);
  for (size_t k = 1; k < 6; ++k) {
    EXPECT_EQ(p.frames[k].capture_utime - p.frames[k - 1].capture_utime, 40'000);
    EXPECT_FALSE(p.frames[k].resized);
    EXPECT_NEAR(p.frames[k].image.at<cv::Vec3b>(20, 20)[0], 40.0 * static_cast<double>(k), 4);
  }
}

TEST(CameraSources, AGstreamerPipelineIsStampedAtGrabMinusTheLatency) {
  CaptureOptions o;
  o.latency_s = 0.25;
  const int64_t before = ptz::wallUtime();
  const Played p = play(
      parseSource("videotestsrc num-buffers=3 ! video/x-raw,width=32,height=24 ! videoconvert ! "
                  "appsink",
                  "x"),
      o);
  const int64_t after = ptz::wallUtime();
  ASSERT_EQ(p.frames.size(), 3u);
  for (const auto& f : p.frames) {
    EXPECT_GE(f.capture_utime, before - 250'000);
    EXPECT_LE(f.capture_utime, after - 250'000);
    EXPECT_EQ(f.image.size(), cv::Size(32, 24));
  }
  // A live stream that ends is a failed read: the supervisor reconnects it.
  EXPECT_EQ(p.last, FrameSource::Poll::kFailed);
  EXPECT_EQ(p.error, "no frame (unplugged?)");
}

TEST(CameraSources, SourcesThatDoNotOpenSayWhichAndWhy) {
  const Played file = play(parseSource("/nonexistent/left.avi", "x"), CaptureOptions{});
  EXPECT_EQ(file.last, FrameSource::Poll::kFailed);
  EXPECT_EQ(file.error, "video file '/nonexistent/left.avi' is missing or unreadable");
  const Played cam = play(parseSource("/dev/video99", "x"), CaptureOptions{});
  EXPECT_EQ(cam.last, FrameSource::Poll::kFailed);
  EXPECT_EQ(cam.error,
            "V4L2 camera '/dev/video99' does not open (missing, busy or no permission?)");
  TempDir dir;
  const Played empty = play(parseSource(dir.path, "x"), CaptureOptions{});
  EXPECT_EQ(empty.last, FrameSource::Poll::kFailed);
  EXPECT_EQ(empty.error, "image folder '" + dir.path + "': no image files in it");
}

TEST(CameraSources, ImagesBecomeEightBitBgrOrGrayOfTheConfiguredSize) {
  cv::Mat deep(4, 6, CV_16UC1, cv::Scalar(512));
  EXPECT_FALSE(normaliseImage(&deep, 6, 4));
  EXPECT_EQ(deep.type(), CV_8UC1);
  EXPECT_EQ(deep.at<uint8_t>(1, 1), 2);
  cv::Mat bgra(4, 6, CV_8UC4, cv::Scalar(1, 2, 3, 255));
  EXPECT_TRUE(normaliseImage(&bgra, 12, 8));
  EXPECT_EQ(bgra.type(), CV_8UC3);
  EXPECT_EQ(bgra.size(), cv::Size(12, 8));
  EXPECT_EQ(bgra.at<cv::Vec3b>(3, 3), cv::Vec3b(1, 2, 3));
  cv::Mat keep(4, 6, CV_8UC3);
  EXPECT_FALSE(normaliseImage(&keep, 0, 0));
}
