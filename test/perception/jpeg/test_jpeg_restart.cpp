// Windows of a JPEG decoded from its restart segments (perception/jpeg/jpeg_restart.hpp): the
// pixels of cv::imdecode's full decode exactly, at VGA and 1080p, 4:2:0 and 4:4:4, restart markers
// at every MCU row, every second row and off the rows; encodeImage's JPEGs take that path; damaged
// restart data takes the whole-stream path or decodes as it would (never a crash).
#include <gtest/gtest.h>
#include <jpeglib.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <cstdlib>
#include <random>

#include "common/transport/transport.hpp"
#include "perception/jpeg/jpeg_window.hpp"
#include "sim/simulator.hpp"
#include "support/detect_scene.hpp"

namespace perception = ptz::perception;
namespace sim = ptz::sim;
using Bytes = std::vector<uint8_t>;

namespace {

// The default scene with a ball and a box, rendered at the rig's size.
cv::Mat rendered(int width, int height) {
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault().atSize(width, height);
  sim::Scene scene;
  scene.objects = {ptz::test::object("red_ball", sim::SceneObject::Shape::kSphere, {0.1, 0.05, 2.5},
                                     ptz::test::kRed),
                   ptz::test::object("green_box", sim::SceneObject::Shape::kBox, {-0.5, 0.2, 2},
                                     ptz::test::kGreen)};
  sim::Simulator s(rig, scene, ptz::defaultPlantParams(), 2.0, 3);
  return s.capture().left;
}

// 4:4:4 (OpenCV 4.6's imencode has no sampling option): libjpeg directly, a restart every
// `interval` MCUs (0: none).
Bytes encode444(const cv::Mat& bgr, int interval) {
  jpeg_compress_struct c{};
  jpeg_error_mgr err{};
  c.err = jpeg_std_error(&err);
  jpeg_create_compress(&c);
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&c, &buf, &size);
  c.image_width = static_cast<JDIMENSION>(bgr.cols);
  c.image_height = static_cast<JDIMENSION>(bgr.rows);
  c.input_components = 3;
  c.in_color_space = JCS_EXT_BGR;
  jpeg_set_defaults(&c);
  jpeg_set_quality(&c, 90, TRUE);
  for (int i = 0; i < 3; ++i) c.comp_info[i].h_samp_factor = c.comp_info[i].v_samp_factor = 1;
  c.restart_interval = static_cast<unsigned int>(interval);
  jpeg_start_compress(&c, TRUE);
  while (c.next_scanline < c.image_height) {
    JSAMPROW row = const_cast<uint8_t*>(bgr.ptr(static_cast<int>(c.next_scanline)));
    jpeg_write_scanlines(&c, &row, 1);
  }
  jpeg_finish_compress(&c);
  Bytes out(buf, buf + size);
  std::free(buf);
  jpeg_destroy_compress(&c);
  return out;
}

Bytes imencode(const cv::Mat& bgr, std::vector<int> params) {
  Bytes out;
  EXPECT_TRUE(cv::imencode(".jpg", bgr, out, params));
  return out;
}

// What the header says: each component's sampling factors (H << 4 | V), the restart interval.
struct Header {
  std::vector<int> sampling;
  int interval = 0;
};
Header parseHeader(const Bytes& j) {
  Header h;
  for (size_t p = 2; p + 4 <= j.size() && j[p] == 0xFF;) {
    const int m = j[p + 1], len = j[p + 2] << 8 | j[p + 3];
    if (m == 0xC0) {
      for (int c = 0; c < j[p + 9]; ++c) h.sampling.push_back(j[p + 11 + 3 * c]);
    }
    if (m == 0xDD) h.interval = j[p + 4] << 8 | j[p + 5];
    if (m == 0xDA) break;
    p += 2 + static_cast<size_t>(len);
  }
  return h;
}

// Edge rectangles and random ones (1x1 to a third of the image).
std::vector<cv::Rect> someRects(cv::Size s, int random, uint32_t seed) {
  const int w = s.width, h = s.height;
  std::vector<cv::Rect> rects = {{0, 0, w, h},          {0, 0, 17, 9},       {w - 17, h - 9, 17, 9},
                                 {0, h - 1, w, 1},      {w - 1, 0, 1, h},    {w / 2, h / 2, 1, 1},
                                 {w - 1, h - 1, 1, 1},  {0, h - 24, 40, 24}, {w - 33, 17, 33, 40},
                                 {5, h / 3, w - 9, 31}, {w / 3, 15, 20, 2},  {w / 3, 16, 20, 16}};
  std::mt19937 rng(seed);
  for (int i = 0; i < random; ++i) {
    const int rw = std::uniform_int_distribution<int>(1, w / 3)(rng);
    const int rh = std::uniform_int_distribution<int>(1, h / 3)(rng);
    rects.emplace_back(std::uniform_int_distribution<int>(0, w - rw)(rng),
                       std::uniform_int_distribution<int>(0, h - rh)(rng), rw, rh);
  }
  return rects;
}

// Every rect alone and in groups, by the free functions and through one index: exactly `whole`'s
// pixels. Returns the restart bands decoded through the index.
int expectExact(const Bytes& jpeg, const cv::Mat& whole, const std::vector<cv::Rect>& rects,
                const std::string& what) {
  const int w = whole.cols, h = whole.rows;
  const perception::JpegRestartIndex index(jpeg.data(), jpeg.size());
  int bands = 0;
  for (const auto& r : rects) {
    cv::Mat part;
    std::string why;
    EXPECT_TRUE(perception::decodeJpegWindow(jpeg.data(), jpeg.size(), w, h, r, &part, &why))
        << what << " " << why;
    EXPECT_EQ(cv::norm(part, whole(r), cv::NORM_INF), 0.0) << what << " rect " << r;
  }
  for (size_t i = 0; i < rects.size(); i += 3) {
    const std::vector<cv::Rect> group(
        rects.begin() + static_cast<ptrdiff_t>(i),
        rects.begin() + static_cast<ptrdiff_t>(std::min(i + 3, rects.size())));
    std::vector<cv::Mat> parts;
    std::string why;
    perception::JpegWindowStats stats;
    EXPECT_TRUE(perception::decodeJpegWindows(index, w, h, group, &parts, &why, &stats))
        << what << " " << why;
    bands += stats.restart_bands;
    for (size_t k = 0; k < group.size() && k < parts.size(); ++k) {
      EXPECT_EQ(cv::norm(parts[k], whole(group[k]), cv::NORM_INF), 0.0)
          << what << " group rect " << group[k];
    }
  }
  return bands;
}

}  // namespace

// ptz-sim and ptz-camera's JPEGs: OpenCV 4.6 writes 4:2:0 (MCUs of 16x16 in colour) and
// encodeImage a restart interval of one MCU row; the index takes them.
// encodeImage's restarts split every MCU row into segments of 8 MCUs (128 px) at VGA and 1080p,
// 7 at 1000 px (63 MCUs a row): a window at the bottom decodes its own rows and columns alone.
TEST(JpegRestart, EncodeImageSplitsEveryMcuRowIntoRestartSegments) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1920, 1080), cv::Size(1000, 1003)}) {
    const cv::Mat image = rendered(size.width, size.height);
    const Bytes jpeg = ptz::encodeImage(image, ptzstereo::image_t::ENCODING_JPEG, 90).data;
    const Header h = parseHeader(jpeg);
    EXPECT_EQ(h.sampling, (std::vector<int>{0x22, 0x11, 0x11})) << size;
    const int per_row = (size.width + 15) / 16, rows = (size.height + 15) / 16;
    const int interval = per_row % 8 == 0 ? 8 : 7;
    EXPECT_EQ(h.interval, interval) << size;
    int markers = 0;
    for (size_t i = 0; i + 1 < jpeg.size(); ++i) {
      markers += jpeg[i] == 0xFF && jpeg[i + 1] >= 0xD0 && jpeg[i + 1] <= 0xD7;
    }
    EXPECT_EQ(markers, rows * (per_row / interval) - 1) << size;
    const perception::JpegRestartIndex index(jpeg.data(), jpeg.size());
    EXPECT_TRUE(index.usable()) << size;
    EXPECT_EQ(index.mcuHeight(), 16);
    EXPECT_EQ(index.mcuRows(), rows);
    EXPECT_EQ(index.bandStart(rows - 1), rows - 1);
    EXPECT_EQ(index.tilesPerRow(), per_row / interval);
    EXPECT_EQ(index.tileWidth(), interval * 16);
    // A window at the bottom: its rows and one MCU row above, not the image above them.
    const cv::Mat whole = cv::imdecode(jpeg, cv::IMREAD_COLOR);
    const cv::Rect bottom(size.width / 2, size.height - 20, 30, 20);
    std::vector<cv::Mat> parts;
    std::string why;
    perception::JpegWindowStats stats;
    ASSERT_TRUE(perception::decodeJpegWindows(index, size.width, size.height, {bottom}, &parts,
                                              &why, &stats))
        << why;
    EXPECT_EQ(stats.restart_bands, 1);
    EXPECT_LE(stats.decoded_rows, 48) << size;
    EXPECT_LE(stats.decoded_width, 3 * interval * 16) << size;  // its tiles, one each side
    EXPECT_EQ(cv::norm(parts[0], whole(bottom), cv::NORM_INF), 0.0);
    // Gray images: MCUs of 8x8, a marker every row of them too (the index takes colour only).
    cv::Mat gray;
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
    const Bytes g = ptz::encodeImage(gray, ptzstereo::image_t::ENCODING_JPEG, 90).data;
    EXPECT_EQ(parseHeader(g).sampling, std::vector<int>{0x11});
    const int gray_per_row = (size.width + 7) / 8;
    EXPECT_EQ(parseHeader(g).interval, gray_per_row % 8 == 0 ? 8 : 5) << size;  // 125 = 5 x 25
  }
}

// Every kind of JPEG, many windows: exactly the full decode's pixels; the restart path taken
// where the markers allow it.
TEST(JpegRestart, WindowsAreExactlyTheFullDecodesPixels) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1920, 1080), cv::Size(1000, 1003)}) {
    const cv::Mat image = rendered(size.width, size.height);
    const int per_row_420 = (size.width + 15) / 16, per_row_444 = (size.width + 7) / 8;
    struct Case {
      std::string name;
      Bytes jpeg;
      bool restarts;  // the restart path expected
    };
    const std::vector<Case> cases = {
        {"encodeImage", ptz::encodeImage(image, ptzstereo::image_t::ENCODING_JPEG, 90).data, true},
        {"4:2:0 no restarts", imencode(image, {cv::IMWRITE_JPEG_QUALITY, 90}), false},
        {"4:2:0 every 2 rows",
         imencode(image,
                  {cv::IMWRITE_JPEG_QUALITY, 90, cv::IMWRITE_JPEG_RST_INTERVAL, 2 * per_row_420}),
         true},
        {"4:2:0 every 7 MCUs", imencode(image, {cv::IMWRITE_JPEG_RST_INTERVAL, 7}), true},
        {"4:2:0 optimised",
         imencode(image,
                  {cv::IMWRITE_JPEG_OPTIMIZE, 1, cv::IMWRITE_JPEG_RST_INTERVAL, per_row_420}),
         true},
        {"progressive",
         imencode(image,
                  {cv::IMWRITE_JPEG_PROGRESSIVE, 1, cv::IMWRITE_JPEG_RST_INTERVAL, per_row_420}),
         false},
        {"4:4:4 no restarts", encode444(image, 0), false},
        {"4:4:4 every row", encode444(image, per_row_444), true},
        {"4:4:4 every 2 rows", encode444(image, 2 * per_row_444), true},
        {"4:4:4 every 3 MCUs", encode444(image, 3), true}};
    for (const Case& c : cases) {
      const std::string what =
          c.name + " " + std::to_string(size.width) + "x" + std::to_string(size.height);
      const perception::JpegRestartIndex index(c.jpeg.data(), c.jpeg.size());
      EXPECT_EQ(index.usable(), c.restarts) << what;
      const cv::Mat whole = cv::imdecode(c.jpeg, cv::IMREAD_COLOR);
      const int bands = expectExact(c.jpeg, whole, someRects(size, 30, 11), what);
      EXPECT_EQ(bands > 0, c.restarts) << what;
    }
  }
}

// A banded full scan's rows reduced (windows.hpp): exactly those rows of the whole image reduced,
// from the rows' own restart segments where there are some, from the stream's top where not.
TEST(JpegRestart, ReducedRowsAreExactlyThoseOfTheWholeReducedDecode) {
  for (const cv::Size size : {cv::Size(640, 480), cv::Size(1920, 1080), cv::Size(1000, 1003)}) {
    const cv::Mat image = rendered(size.width, size.height);
    for (const bool restarts : {true, false}) {
      const Bytes jpeg = restarts
                             ? ptz::encodeImage(image, ptzstereo::image_t::ENCODING_JPEG, 90).data
                             : imencode(image, {cv::IMWRITE_JPEG_QUALITY, 90});
      const perception::JpegRestartIndex index(jpeg.data(), jpeg.size());
      ASSERT_EQ(index.usable(), restarts);
      for (const int scale : {2, 4, 8}) {
        cv::Mat whole;
        std::string why;
        ASSERT_TRUE(perception::decodeJpegReduced(jpeg.data(), jpeg.size(), size.width, size.height,
                                                  scale, &whole, &why))
            << why;
        const int h = size.height;
        for (const auto& [row0, row1] :
             std::vector<std::pair<int, int>>{{0, 40},
                                              {8 * 16, 8 * 16 + 1},
                                              {h / 2 / 8 * 8, h / 2 + 123},
                                              {(h - 200) / 8 * 8, h},
                                              {h / 3 / 8 * 8, h - 1},
                                              {0, h}}) {
          const std::string what = std::to_string(size.width) + "x" + std::to_string(h) +
                                   (restarts ? " restarts" : " none") + " scale " +
                                   std::to_string(scale) + " rows " + std::to_string(row0) + ".." +
                                   std::to_string(row1);
          cv::Mat rows;
          perception::JpegWindowStats stats;
          ASSERT_TRUE(perception::decodeJpegReducedRows(index, size.width, h, scale, row0, row1,
                                                        &rows, &why, &stats))
              << what << ": " << why;
          const int r0 = row0 / scale, r1 = (row1 + scale - 1) / scale;
          ASSERT_EQ(rows.size(), cv::Size(whole.cols, r1 - r0)) << what;
          EXPECT_EQ(cv::norm(rows, whole.rowRange(r0, r1), cv::NORM_INF), 0.0) << what;
          // Below the first two MCU rows, restarts spare the rows above (and those below).
          EXPECT_EQ(stats.restart_bands, restarts && row0 >= 32 ? 1 : 0) << what;
          if (restarts && row0 >= 32) {
            EXPECT_LE(stats.decoded_rows, row1 - row0 + 64) << what;  // MCU rows, one each side
          }
        }
        // Rows not in the image, or not starting a reduced row: refused, *out untouched.
        cv::Mat untouched;
        for (const auto& [row0, row1] :
             std::vector<std::pair<int, int>>{{-8, 8}, {0, h + 1}, {40, 40}, {50, 10}, {1, 9}}) {
          if (row0 % scale == 0 && row0 >= 0 && row0 < row1 && row1 <= h) continue;
          EXPECT_FALSE(perception::decodeJpegReducedRows(index, size.width, h, scale, row0, row1,
                                                         &untouched, &why));
          EXPECT_TRUE(untouched.empty());
        }
      }
    }
  }
}

// Windows apart (in rows or in columns) decode as bands apart, windows near as one; either way
// the same pixels.
TEST(JpegRestart, BandsPerGroupOfWindows) {
  const cv::Mat image = rendered(1920, 1080);
  const Bytes jpeg = ptz::encodeImage(image, ptzstereo::image_t::ENCODING_JPEG, 90).data;
  const cv::Mat whole = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  const perception::JpegRestartIndex index(jpeg.data(), jpeg.size());
  struct Case {
    std::vector<cv::Rect> rects;
    int bands;  // from restart segments: tiles of 128 px, one of context each side
  };
  for (const Case& c :
       std::vector<Case>{{{{100, 200, 50, 50}, {1500, 900, 60, 60}}, 2},
                         {{{100, 200, 50, 50}, {1500, 210, 60, 60}}, 2},
                         {{{100, 200, 50, 50}, {200, 230, 60, 60}}, 1},
                         {{{100, 200, 50, 50}, {400, 264, 60, 60}}, 1},
                         {{{0, 0, 50, 20}, {900, 500, 60, 60}, {9, 1070, 9, 10}}, 3},
                         {{{0, 0, 50, 40}, {300, 48, 60, 60}}, 1}}) {
    std::vector<cv::Mat> parts;
    std::string why;
    perception::JpegWindowStats stats;
    ASSERT_TRUE(perception::decodeJpegWindows(index, 1920, 1080, c.rects, &parts, &why, &stats))
        << why;
    EXPECT_EQ(stats.restart_bands, c.bands) << c.rects[1];
    for (size_t i = 0; i < c.rects.size(); ++i) {
      EXPECT_EQ(cv::norm(parts[i], whole(c.rects[i]), cv::NORM_INF), 0.0) << c.rects[i];
    }
  }
}

// Damaged restart data: the index refuses what is inconsistent (the whole-stream path then), and
// what it takes decodes exactly as the whole stream does. Never a crash.
TEST(JpegRestart, DamagedRestartDataTakesTheStreamPathOrDecodesAsIt) {
  const cv::Mat image = rendered(640, 480);
  const Bytes good = ptz::encodeImage(image, ptzstereo::image_t::ENCODING_JPEG, 90).data;
  const cv::Mat whole = cv::imdecode(good, cv::IMREAD_COLOR);
  std::vector<size_t> rst;  // offsets of the markers' FF
  for (size_t i = 0; i + 1 < good.size(); ++i) {
    if (good[i] == 0xFF && good[i + 1] >= 0xD0 && good[i + 1] <= 0xD7) rst.push_back(i);
  }
  ASSERT_EQ(rst.size(), 30u * 5 - 1);  // 30 MCU rows of 5 segments
  size_t dri = 0;
  for (size_t i = 0; i + 5 < good.size() && dri == 0; ++i) {
    if (good[i] == 0xFF && good[i + 1] == 0xDD) dri = i + 4;
  }
  ASSERT_GT(dri, 0u);
  const auto erase = [&](size_t at, size_t n) {
    Bytes b = good;
    b.erase(b.begin() + static_cast<ptrdiff_t>(at), b.begin() + static_cast<ptrdiff_t>(at + n));
    return b;
  };
  const auto insert = [&](size_t at, Bytes what) {
    Bytes b = good;
    b.insert(b.begin() + static_cast<ptrdiff_t>(at), what.begin(), what.end());
    return b;
  };
  const auto set = [&](size_t at, uint8_t v) {
    Bytes b = good;
    b[at] = v;
    return b;
  };
  struct Case {
    std::string name;
    Bytes jpeg;
    bool usable;
    bool exact;  // still a valid JPEG of the same pixels
  };
  const std::vector<Case> cases = {
      {"a marker removed", erase(rst[10], 2), false, false},
      {"a marker duplicated", insert(rst[10], {0xFF, good[rst[10] + 1]}), false, false},
      {"markers out of sequence", set(rst[10] + 1, good[rst[11] + 1]), false, false},
      {"a segment emptied", erase(rst[10] + 2, rst[11] - rst[10] - 2), false, false},
      {"DRI halved", set(dri + 1, good[dri + 1] / 2), false, false},
      {"DRI doubled", set(dri + 1, static_cast<uint8_t>(good[dri + 1] * 2)), false, false},
      {"DRI zero", set(dri + 1, 0), false, false},
      {"truncated in a segment",
       Bytes(good.begin(), good.begin() + static_cast<ptrdiff_t>(rst[20] - 7)), false, false},
      {"truncated after a marker",
       Bytes(good.begin(), good.begin() + static_cast<ptrdiff_t>(rst[20] + 2)), false, false},
      {"no EOI", Bytes(good.begin(), good.end() - 2), false, false},
      {"a marker where EOI is", set(good.size() - 1, 0xD5), false, false},
      {"fill bytes before a marker", insert(rst[10], {0xFF, 0xFF, 0xFF}), true, true},
      {"stuffed FF before a marker", insert(rst[10], {0xFF, 0x00}), true, false},
      {"stuffed FF after a marker", insert(rst[10] + 2, {0xFF, 0x00}), true, false},
      {"fill bytes then a stuffed FF", insert(rst[10] + 2, {0xFF, 0xFF, 0x00}), true, false},
      {"bytes of a segment changed",
       set(rst[15] - 3, static_cast<uint8_t>(good[rst[15] - 3] ^ 0x5A)), true, false},
      {"garbage after EOI", insert(good.size(), {0x12, 0xFF, 0xD3}), true, true}};
  for (const Case& c : cases) {
    const perception::JpegRestartIndex index(c.jpeg.data(), c.jpeg.size());
    const perception::JpegRestartIndex stream(c.jpeg.data(), c.jpeg.size(), false);
    EXPECT_EQ(index.usable(), c.usable) << c.name;
    for (const auto& r : someRects({640, 480}, 20, 5)) {
      std::vector<cv::Mat> got, want;
      std::string why, why_stream;
      const bool ok = perception::decodeJpegWindows(index, 640, 480, {r}, &got, &why);
      const bool ok_stream =
          perception::decodeJpegWindows(stream, 640, 480, {r}, &want, &why_stream);
      ASSERT_EQ(ok, ok_stream) << c.name << " " << r << " " << why << " / " << why_stream;
      if (!ok) {
        EXPECT_FALSE(why.empty());
        continue;
      }
      ASSERT_EQ(got[0].size(), r.size());
      EXPECT_EQ(cv::norm(got[0], want[0], cv::NORM_INF), 0.0) << c.name << " " << r;
      if (c.exact) {
        EXPECT_EQ(cv::norm(got[0], whole(r), cv::NORM_INF), 0.0) << c.name << " " << r;
      }
    }
  }
  // A header that lies about the size, and bytes that are no JPEG: refused, cleanly.
  std::vector<cv::Mat> parts;
  std::string why;
  const perception::JpegRestartIndex index(good.data(), good.size());
  EXPECT_FALSE(perception::decodeJpegWindows(index, 640, 464, {{0, 0, 8, 8}}, &parts, &why));
  const Bytes junk(1000, 0xFF);
  const perception::JpegRestartIndex none(junk.data(), junk.size());
  EXPECT_FALSE(none.usable());
  EXPECT_FALSE(perception::decodeJpegWindows(none, 640, 480, {{0, 0, 8, 8}}, &parts, &why));
  EXPECT_TRUE(parts.empty());
}
