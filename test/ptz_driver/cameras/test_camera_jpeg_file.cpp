// Recorded JPEGs passed through undecoded (issue #18): the header check on good and hostile bytes,
// and an image folder read by a real capture source: its JPEGs delivered as their bytes when the
// output is JPEG, decoded otherwise, a file that does not decode skipped, counted and named.
#include <gtest/gtest.h>
#include <poll.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "common/measure.hpp"
#include "ptz_driver/cameras/sources/capture_source.hpp"
#include "ptz_driver/cameras/sources/jpeg_file.hpp"
#include "ptz_driver/cameras/sources/source_supervisor.hpp"

using namespace ptz::driver;

namespace {

std::vector<uint8_t> jpegOf(int width, int height, int channels = 3) {
  cv::Mat img(height, width, channels == 3 ? CV_8UC3 : CV_8UC1);
  cv::randu(img, 0, 255);
  std::vector<uint8_t> out;
  cv::imencode(".jpg", img, out, {cv::IMWRITE_JPEG_QUALITY, 90});
  return out;
}

// checkPassThroughJpeg's answer: "" when it passes (and the size is w x h), else why.
std::string check(const std::vector<uint8_t>& bytes, int width, int height) {
  int w = -1, h = -1;
  std::string why;
  if (!checkPassThroughJpeg(bytes.data(), bytes.size(), width, height, &w, &h, &why)) return why;
  return std::to_string(w) + "x" + std::to_string(h);
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

}  // namespace

TEST(JpegPassThrough, AColourJpegOfThePublishedSizePasses) {
  const auto jpeg = jpegOf(64, 48);
  EXPECT_EQ(check(jpeg, 64, 48), "64x48");
  EXPECT_EQ(check(jpeg, 0, 0), "64x48");  // as delivered
  auto padded = jpeg;
  padded.insert(padded.end(), 16, 0);  // zero padding after the end marker, as cameras send
  EXPECT_EQ(check(padded, 64, 48), "64x48");
}

TEST(JpegPassThrough, AnythingElseIsRefusedWithTheReason) {
  const auto jpeg = jpegOf(64, 48);
  EXPECT_TRUE(contains(check(jpeg, 32, 24), "JPEG of 64x48, published at 32x24"));
  EXPECT_TRUE(contains(check({}, 64, 48), "not a JPEG"));
  EXPECT_TRUE(contains(check({0xFF, 0xD8}, 64, 48), "not a JPEG"));
  EXPECT_TRUE(contains(check({'G', 'I', 'F', '8', '9', 'a', 0, 0}, 64, 48), "not a JPEG"));
  // Cut inside the header, and inside the scan.
  EXPECT_TRUE(contains(check({jpeg.begin(), jpeg.begin() + 40}, 64, 48), "JPEG header"));
  EXPECT_EQ(check({jpeg.begin(), jpeg.begin() + static_cast<long>(jpeg.size()) - 100}, 64, 48),
            "JPEG truncated (no end-of-image marker)");
  EXPECT_TRUE(contains(check(jpegOf(64, 48, 1), 64, 48), "1 components, not 3"));
  // A header claiming 60000 x 60000 over a few bytes.
  auto forged = jpeg;
  for (size_t i = 0; i + 8 < forged.size(); ++i) {
    if (forged[i] == 0xFF && forged[i + 1] == 0xC0) {  // SOF0: length, precision, height, width
      forged[i + 5] = forged[i + 7] = 0xEA;
      forged[i + 6] = forged[i + 8] = 0x60;
      break;
    }
  }
  EXPECT_TRUE(contains(check(forged, 0, 0), "JPEG of 60000x60000 outside 1..4096"));
  // An EXIF segment (its orientation would turn the image in a decoder).
  auto exif = jpeg;
  const std::vector<uint8_t> app1 = {0xFF, 0xE1, 0x00, 0x0A, 'E', 'x', 'i', 'f', 0, 0, 0, 0};
  exif.insert(exif.begin() + 2, app1.begin(), app1.end());
  EXPECT_TRUE(contains(check(exif, 64, 48), "EXIF"));
}

TEST(JpegPassThrough, AFileThatCannotBeReadIsNamed) {
  std::vector<uint8_t> bytes;
  std::string why;
  EXPECT_FALSE(readFileBytes("/nonexistent/000001.jpg", &bytes, &why));
  EXPECT_EQ(why, "image file '/nonexistent/000001.jpg' cannot be read");
}

namespace {

struct Folder {
  std::string path;
  std::vector<std::vector<uint8_t>> files;
  Folder() {
    char tmpl[] = "/tmp/ptz_camera_jpeg_XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~Folder() { std::system(("rm -rf '" + path + "'").c_str()); }
  void add(const std::vector<uint8_t>& bytes) {
    const std::string name = path + "/" + std::to_string(10 + files.size()) + ".jpg";
    std::ofstream(name, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), static_cast<long>(bytes.size()));
    files.push_back(bytes);
  }
};

struct Played {
  std::unique_ptr<SourceSupervisor> sup;
  std::vector<CapturedFrame> frames;
};

// Every frame of a folder through a supervised capture source, played at 1 kHz.
Played playFolder(const std::string& folder, bool pass_jpeg) {
  CaptureOptions o;
  o.width = 64;
  o.height = 48;
  o.file_fps = 1000;
  o.pass_jpeg = pass_jpeg;
  auto notifier = std::make_shared<FrameNotifier>();
  Played p;
  auto& sup = p.sup;
  sup = std::make_unique<SourceSupervisor>(
      "left source " + folder,
      makeCaptureFactory(parseSource(folder, "left_source"), o, std::make_shared<PlaybackClock>(),
                         notifier),
      SupervisorParams{}, false);
  const int64_t deadline = ptz::wallUtime() + 10'000'000;
  while (sup->state() != SourceSupervisor::State::kEnded && ptz::wallUtime() < deadline) {
    sup->step(static_cast<double>(ptz::wallUtime()) * 1e-6, &p.frames);
    pollfd fd{notifier->fd(), POLLIN, 0};
    ::poll(&fd, 1, 100);
    notifier->drain();
  }
  return p;
}

}  // namespace

TEST(JpegPassThrough, AFolderDeliversItsJpegsAsTheirBytesWhenTheOutputIsJpeg) {
  Folder dir;
  dir.add(jpegOf(64, 48));
  dir.add(jpegOf(128, 96));    // another size: decoded and resized
  dir.add(jpegOf(64, 48, 1));  // grey: decoded to colour
  const auto frames = playFolder(dir.path, true).frames;
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].jpeg, dir.files[0]);
  EXPECT_EQ(frames[0].jpeg_size, cv::Size(64, 48));
  EXPECT_TRUE(frames[0].image.empty());
  for (size_t i = 1; i < 3; ++i) {
    EXPECT_TRUE(frames[i].jpeg.empty());
    EXPECT_EQ(frames[i].image.size(), cv::Size(64, 48));
    EXPECT_EQ(frames[i].image.type(), CV_8UC3);
  }
  EXPECT_TRUE(frames[1].resized);
  const auto decoded = playFolder(dir.path, false).frames;  // raw output: every one decoded
  ASSERT_EQ(decoded.size(), 3u);
  for (const auto& f : decoded) EXPECT_TRUE(f.jpeg.empty() && !f.image.empty());
}

TEST(JpegPassThrough, AFileThatDoesNotDecodeIsSkippedCountedAndNamed) {
  Folder dir;
  dir.add(jpegOf(64, 48));
  dir.add({'n', 'o', 't', ' ', 'a', ' ', 'j', 'p', 'e', 'g'});
  dir.add(jpegOf(64, 48));
  const Played p = playFolder(dir.path, true);
  const auto& frames = p.frames;
  SourceSupervisor* sup = p.sup.get();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].jpeg, dir.files[2]);
  // Its time stays its own: the third file is two periods after the first.
  EXPECT_EQ(frames[1].capture_utime - frames[0].capture_utime, 2000);
  EXPECT_EQ(sup->skipped(), 1);
  EXPECT_EQ(sup->lastSkipped(), "image file '" + dir.path + "/11.jpg' does not decode");
  const auto events = sup->takeEvents();
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events[0], "left source " + dir.path + ": image file '" + dir.path +
                           "/11.jpg' does not decode, skipped (1 so far)");
}
