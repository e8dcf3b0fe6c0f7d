// What the fuzz targets of fuzz/ found in common/, each from its reproducer in fuzz/corpus/: files
// that made OpenCV's parser loop forever, throw past the loaders or allocate a matrix's declared
// size first (fixed in config.cpp and storage_guard.cpp), and messages that passed the checks of
// message_check.cpp yet did not survive a decode and re-encode, or cost far more than their size.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <future>
#include <iterator>
#include <vector>

#include "common/config.hpp"
#include "common/rig.hpp"
#include "common/transport/message_check.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/process_status_t.hpp"

namespace {

std::string corpus(const std::string& target, const std::string& name) {
  return PTZ_SOURCE_DIR "/fuzz/corpus/" + target + "/" + name;
}

std::vector<uint8_t> readBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), {});
}

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = std::string(::testing::TempDir()) + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// The error of loading `path`, or "" if it loaded. A parser that loops would hang the test: it
// is given 10 s on another thread, then the test binary ends (no thread can be stopped).
std::string loadError(const std::function<void()>& load) {
  auto done = std::async(std::launch::async, [&] {
    try {
      load();
    } catch (const ptz::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  });
  if (done.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
    std::fprintf(stderr, "the load did not finish in 10 s: the parser loops\n");
    std::_Exit(1);
  }
  return done.get();
}

template <class Msg>
std::vector<uint8_t> bytesOf(const Msg& m) {
  std::vector<uint8_t> b(static_cast<size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

}  // namespace

TEST(FuzzFinds, YamlFilesOnWhichOpenCvLoopsAreRefusedNamingTheFile) {
  const std::vector<std::pair<std::string, std::string>> finds = {
      {"fuzz_config", "find-hang-indented-top-level"},
      {"fuzz_config", "find-hang-nul-in-a-line"},
      {"fuzz_pelco_model", "find-hang-content-after-marker"},
      {"fuzz_visca_model", "find-hang-second-document"},
      {"fuzz_scene", "find-hang-second-document"},
      {"fuzz_scene", "find-hang-indented-directive"}};
  for (const auto& [target, name] : finds) {
    const std::string path = corpus(target, name);
    const std::string error = loadError([&] { ptz::openForRead(path, "config file"); });
    EXPECT_NE(error.find("config file '" + path + "': malformed (line "), std::string::npos)
        << name << ": " << error;
  }
  // OpenCV's XML reader dereferenced NULL on this one: only YAML is read.
  const std::string xml = corpus("fuzz_config", "find-xml-reader-segfault");
  EXPECT_NE(loadError([&] {
              ptz::openForRead(xml, "config file");
            }).find("config file '" + xml + "': malformed (line 1: not YAML"),
            std::string::npos);
  // The forms the project writes still load: a directive, the marker, a block map in column 1.
  const std::string good = writeTemp(
      "good.yaml", "%YAML:1.0\n---\n# comment\nframes: 3\nobjects:\n  - { name: \"a\" }\n");
  EXPECT_EQ(loadError([&] { ptz::openForRead(good, "config file"); }), "");
}

TEST(FuzzFinds, AConfigFileWhoseTopLevelIsNotAMapIsAConfigError) {
  // As fuzz/corpus/fuzz_config/find-top-level-is-a-list (OpenCV asserted on a list item's name).
  const std::string path = writeTemp("list.yaml", "%YAML:1.0\n---\n- 1\n- { a: 2 }\n");
  ptz::Params p("prog", "test");
  const std::string error = loadError([&] { p.parseConfigFile(path); });
  EXPECT_NE(error.find("config file '" + path + "': must be a map of parameters, got a list"),
            std::string::npos)
      << error;
}

TEST(FuzzFinds, WhatOpenCvThrowsWhileParsingIsAConfigErrorNamingTheFile) {
  // OpenCV threw std::length_error out of FileStorage::open: it escaped StereoRig::load.
  const std::string path = corpus("fuzz_rig", "find-length-error-escapes");
  const std::string error = loadError([&] { ptz::StereoRig::load(path); });
  EXPECT_NE(error.find("rig file '" + path + "'"), std::string::npos) << error;
}

TEST(FuzzFinds, AMatrixMustHoldTheSizeAndOneChannelBeforeItIsRead) {
  // The reproducers declare 1e8 x 3 and 2^31 x 3 camera matrices in a few bytes (OpenCV
  // allocated them before it read the data: out of memory under the fuzzers' AddressSanitizer),
  // and a matrix that is a string (the size check's own operator[] asserted).
  for (const char* name : {"find-matrix-rows-allocated-first", "find-matrix-16g-allocated-first",
                           "find-matrix-not-a-map"}) {
    const std::string path = corpus("fuzz_rig", name);
    const std::string error = loadError([&] { ptz::StereoRig::load(path); });
    EXPECT_NE(error.find("rig file '" + path + "'"), std::string::npos) << name << ": " << error;
  }
  // A 3x3 matrix of three channels (27 numbers) was read as 3x9: intrinsics from wrong places.
  ptz::StereoRig::makeDefault().save(std::string(::testing::TempDir()) + "/rig3.yaml");
  std::ifstream in(std::string(::testing::TempDir()) + "/rig3.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), {});
  const size_t matrix = text.find("camera_matrix: !!opencv-matrix");
  ASSERT_NE(matrix, std::string::npos);
  const size_t dt = text.find("dt: d", matrix), data = text.find("data: [", matrix);
  ASSERT_LT(dt, data);
  text.replace(dt, 5, "dt: \"3d\"");
  const size_t open = text.find('[', data);
  text.insert(open + 1, "1., 2., 3., 4., 5., 6., 7., 8., 9., 1., 2., 3., 4., 5., 6., 7., 8., 9., ");
  const std::string path = writeTemp("rig_3_channels.yaml", text);
  const std::string error = loadError([&] { ptz::StereoRig::load(path); });
  EXPECT_NE(error.find("camera_matrix: must be a 3x3 matrix"), std::string::npos) << error;
}

// Found by fuzz_process_status (fixed in checkEncoding): lcm-gen decodes a string as its length
// minus one byte and
// encodes it up to its first NUL, so a string whose last byte is not NUL, or with a NUL inside,
// passes checkEncoding and comes back different (with a NUL inside, getEncodedSize() is larger
// than what encode() writes: LCM's publish then sends uninitialised bytes after the message).
TEST(FuzzFinds, AStringMustEndInItsNulAndHoldNoOther) {
  ptzstereo::process_status_t status{};
  status.process = "ptz-detect";
  status.hostname = "rig";
  std::vector<uint8_t> b = bytesOf(status);
  std::string why;
  ASSERT_TRUE(ptz::checkEncoding<ptzstereo::process_status_t>(b.data(), b.size(), &why)) << why;
  // hostname: fingerprint, utime, "ptz-detect" (4 + 11), then its length (4) and "rig\0".
  const size_t terminator = 8 + 8 + 15 + 4 + 3;
  ASSERT_EQ(b[terminator], 0);
  b[terminator] = 0x10;
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::process_status_t>(b.data(), b.size(), &why))
      << "a hostname ending in 0x10 instead of its NUL";

  ptzstereo::object_detections_t d{};
  d.left.resize(1);
  d.left[0].class_name = "red_ball";
  d.num_left = 1;
  std::vector<uint8_t> e = bytesOf(d);
  // class_name: fingerprint, three int64, num_left, its length (4), then "red_ball\0".
  e[8 + 24 + 4 + 4 + 3] = 0;
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::object_detections_t>(e.data(), e.size(), &why))
      << "a class_name with a NUL inside ('red\\0ball')";
  // The fuzzers' reproducers.
  const auto status_find =
      readBytes(corpus("fuzz_process_status", "find-string-terminator-not-nul"));
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::process_status_t>(status_find.data(),
                                                               status_find.size(), &why));
  const auto det_find =
      readBytes(corpus("fuzz_object_detections", "find-string-with-a-nul-inside"));
  EXPECT_FALSE(
      ptz::checkEncoding<ptzstereo::object_detections_t>(det_find.data(), det_find.size(), &why));
}

// Found by fuzz_image (fixed in checkImage: at least a bit per 8x8 block): a JPEG's header was
// checked against the message, but not against its own size. 634 bytes that claim the largest size
// allowed pass checkImage, and decodeImage then decodes them (libjpeg fills the missing data): at
// 4096x4096, 120-330 ms and 48 MB per image, where the issue asks that a message cost at most a
// small multiple of its size and less than a frame period.
TEST(FuzzFinds, ATinyJpegThatClaimsTheLargestSizeIsRefusedBeforeDecoding) {
  const int side = ptz::kMaxImageSidePx;
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", cv::Mat(16, 16, CV_8UC3, cv::Scalar(40, 80, 200)), jpeg);
  for (size_t i = 0; i + 9 < jpeg.size(); ++i) {
    if (jpeg[i] == 0xFF && jpeg[i + 1] == 0xC0) {  // start of frame: height, width at +5
      jpeg[i + 5] = jpeg[i + 7] = static_cast<uint8_t>(side >> 8);
      jpeg[i + 6] = jpeg[i + 8] = static_cast<uint8_t>(side & 0xFF);
      break;
    }
  }
  ptzstereo::image_t m{};
  m.width = m.height = side;
  m.pixel_format = ptzstereo::image_t::PIXEL_BGR8;
  m.encoding = ptzstereo::image_t::ENCODING_JPEG;
  m.zoom = 1;
  m.data = jpeg;
  m.data_size = static_cast<int32_t>(jpeg.size());
  std::string why;
  EXPECT_FALSE(ptz::checkImage(m, ptz::kMaxImageSidePx, &why))
      << jpeg.size() << " bytes of JPEG that claim " << side << "x" << side << " pass the checks";
}

// Found by fuzz_jpeg (fixed: readJpegHeader requires FF D8 FF): libjpeg reads
// a header past garbage after the start-of-image marker, so 135 bytes starting FF D8 0A pass
// checkImage as a 32x24 JPEG; cv::imdecode then picks its decoder by the bytes' own signature —
// not JPEG (FF D8 FF), but DICOM ("DICM" at byte 128) — and GDCM asserts: abort(), one
// STEREO_FRAME ends ptz-detect. The frame must be refused, or decoded as it says, and the
// process live on.
TEST(FuzzFindsDeathTest, AJpegThatOpenCvTakesForAnotherFormatDoesNotEndTheProcess) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const std::vector<uint8_t> find =
      readBytes(corpus("fuzz_jpeg", "find-imdecode-picks-dicom-and-aborts"));
  ASSERT_GT(find.size(), 5u);
  ptzstereo::image_t m{};
  m.pixel_format = static_cast<int8_t>(find[0]);  // fuzz_jpeg's prefix: format, width, height
  m.width = find[1] << 8 | find[2];
  m.height = find[3] << 8 | find[4];
  m.encoding = ptzstereo::image_t::ENCODING_JPEG;
  m.zoom = 1;
  m.data.assign(find.begin() + 5, find.end());
  m.data_size = static_cast<int32_t>(m.data.size());
  EXPECT_EXIT(
      {
        cv::Mat out;
        std::string why;
        const bool decoded = ptz::decodeImage(m, &out, &why);
        const bool as_said = out.cols == m.width && out.rows == m.height && out.type() == CV_8UC3;
        std::exit(!decoded || as_said ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}
