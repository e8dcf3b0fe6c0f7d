// Messages are checked against the bytes they came in before anything is allocated, against
// lcm-gen's own encoder: every well-formed message passes, every truncation and every count
// larger than the bytes behind it fails, and a JPEG's header is read before its pixels.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <vector>

#include "common/transport/message_check.hpp"
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
#include "ptzstereo/target_select_t.hpp"

namespace {

template <class Msg>
std::vector<uint8_t> bytesOf(const Msg& m) {
  std::vector<uint8_t> b(static_cast<size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

void putInt32(std::vector<uint8_t>* b, size_t at, int32_t v) {
  for (int i = 0; i < 4; ++i)
    (*b)[at + i] = static_cast<uint8_t>(static_cast<uint32_t>(v) >> (24 - 8 * i));
}

// Accepted whole; every proper prefix and one byte more refused; decodes to the same bytes.
template <class Msg>
void expectExact(const Msg& m) {
  const std::vector<uint8_t> b = bytesOf(m);
  std::string why;
  ASSERT_TRUE(ptz::checkEncoding<Msg>(b.data(), b.size(), &why)) << why;
  Msg back;
  ASSERT_TRUE(ptz::decodeChecked(b.data(), b.size(), &back, &why)) << why;
  EXPECT_EQ(bytesOf(back), b);
  for (size_t n = 0; n < b.size(); ++n) {
    EXPECT_FALSE(ptz::checkEncoding<Msg>(b.data(), n, &why))
        << Msg::getTypeName() << " cut at " << n;
  }
  std::vector<uint8_t> longer = b;
  longer.push_back(0);
  EXPECT_FALSE(ptz::checkEncoding<Msg>(longer.data(), longer.size(), &why));
  EXPECT_NE(why.find("after the message"), std::string::npos) << why;
}

ptzstereo::object_tracks_t tracks(int n) {
  ptzstereo::object_tracks_t m{};
  m.target_id = -1;
  m.target_reason = "locked";
  m.tracks.resize(static_cast<size_t>(n));
  m.num_tracks = n;
  return m;
}

// In object_tracks_t: the fingerprint, three int64, two ptz_head_setpoint_t, target_id.
constexpr size_t kTargetReasonAt = 8 + 3 * 8 + 2 * 3 * 8 + 8;
// In target_select_t: the fingerprint, utime, publish_utime, mode.
constexpr size_t kSelectClassNameAt = 8 + 2 * 8 + 1;
// In control_state_t: the fingerprint, three int64, state, target_id, since_target_s, the two
// waypoint counts.
constexpr size_t kControlReasonAt = 8 + 3 * 8 + 1 + 2 * 8 + 2 * 4;

ptzstereo::stereo_frame_t frame() {
  cv::Mat bgr(6, 8, CV_8UC3, cv::Scalar(10, 20, 30));
  return ptz::makeStereoFrame(1, 2, bgr, {0.1, 0.2, 1.5}, bgr, {0, 0, 1},
                              ptzstereo::image_t::ENCODING_RAW, 90);
}

}  // namespace

TEST(MessageCheck, EveryTypeAcceptedWholeAndRefusedCut) {
  expectExact(frame());
  ptzstereo::object_detections_t det{};
  det.left.resize(2);
  det.left[1].class_name = "red_ball";
  det.num_left = 2;
  det.right.resize(1);
  det.num_right = 1;
  expectExact(det);
  ptzstereo::object_pose_t pose{};
  pose.objects.resize(3);
  pose.objects[2].class_name = "box";
  pose.num_objects = 3;
  expectExact(pose);
  ptzstereo::point_cloud_t cloud{};
  cloud.frame_id = "head";
  cloud.fields.resize(2);
  cloud.fields[0].name = "x";
  cloud.num_fields = 2;
  cloud.data.assign(24, 7);
  cloud.data_size = 24;
  expectExact(cloud);
  ptzstereo::process_status_t status{};
  status.process = "ptz-detect";
  status.channels.resize(2);
  status.channels[0].channel = "STEREO_FRAME";
  status.num_channels = 2;
  status.counters.push_back({"dropped_undecodable", 3});
  status.num_counters = 1;
  expectExact(status);
  expectExact(ptzstereo::ptz_setpoint_t{});
  expectExact(ptzstereo::ptz_state_t{});
  ptzstereo::sim_truth_t truth{};
  truth.objects.resize(2);
  truth.objects[0].name = "ball";
  truth.num_objects = 2;
  expectExact(truth);
  ptzstereo::object_tracks_t tr = tracks(2);
  tr.tracks[0].class_name = "red_ball";
  tr.tracks[1].has_orientation = true;
  tr.target_id = 3;
  expectExact(tr);
  // One track of an empty name: num_tracks exactly fills the bytes left (the smallest track).
  expectExact(tracks(1));
  expectExact(tracks(0));
  ptzstereo::target_select_t select{};
  select.mode = ptzstereo::target_select_t::MODE_CLASS;
  select.class_name = "red_ball";
  expectExact(select);
  expectExact(ptzstereo::target_select_t{});
  ptzstereo::control_state_t control{};
  control.state = ptzstereo::control_state_t::STATE_SEARCHING;
  control.target_id = -1;
  control.search_waypoint = 2;
  control.search_waypoints = 8;
  control.reason = "no target: searching, waypoint 3 of 8";
  expectExact(control);
  expectExact(ptzstereo::control_state_t{});
}

TEST(MessageCheck, CountsLargerThanTheBytesBehindThemAreRefusedBeforeAllocation) {
  // left.data_size sits after the fingerprint, three int64 and the image's 38 header bytes.
  std::vector<uint8_t> b = bytesOf(frame());
  putInt32(&b, 8 + 24 + 38, 2147483647);
  ptzstereo::stereo_frame_t m;
  std::string why;
  EXPECT_FALSE(ptz::decodeChecked(b.data(), b.size(), &m, &why));
  EXPECT_NE(why.find("data_size = 2147483647"), std::string::npos) << why;
  EXPECT_EQ(m.left.data.capacity(), 0u) << "allocated for a count the bytes do not hold";
  putInt32(&b, 8 + 24 + 38, -5);
  EXPECT_FALSE(ptz::decodeChecked(b.data(), b.size(), &m, &why));
  EXPECT_NE(why.find("negative"), std::string::npos) << why;

  ptzstereo::object_pose_t pose{};
  std::vector<uint8_t> p = bytesOf(pose);
  putInt32(&p, p.size() - 4, 10'000'000);  // num_objects is the last field of an empty pose
  EXPECT_FALSE(ptz::decodeChecked(p.data(), p.size(), &pose, &why));
  EXPECT_EQ(pose.objects.capacity(), 0u);

  ptzstereo::object_tracks_t tr = tracks(0);
  std::vector<uint8_t> t = bytesOf(tr);
  putInt32(&t, t.size() - 4, 10'000'000);  // num_tracks is the last field without tracks
  EXPECT_FALSE(ptz::decodeChecked(t.data(), t.size(), &tr, &why));
  EXPECT_NE(why.find("num_tracks = 10000000"), std::string::npos) << why;
  EXPECT_EQ(tr.tracks.capacity(), 0u) << "allocated for a count the bytes do not hold";
  // One track's bytes behind a count of two (a track takes at least 367 bytes).
  t = bytesOf(tracks(1));
  putInt32(&t, kTargetReasonAt + 4 + 7, 2);
  EXPECT_FALSE(ptz::decodeChecked(t.data(), t.size(), &tr, &why));
  EXPECT_NE(why.find("num_tracks = 2 but only 367 bytes follow"), std::string::npos) << why;
  EXPECT_EQ(tr.tracks.capacity(), 0u);

  // A string length of 0 (lcm-gen would assign length -1) and one past the end.
  ptzstereo::process_status_t status{};
  std::vector<uint8_t> s = bytesOf(status);
  putInt32(&s, 8 + 8, 0);
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::process_status_t>(s.data(), s.size(), &why));
  putInt32(&s, 8 + 8, 1 << 30);
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::process_status_t>(s.data(), s.size(), &why));
  // Another type's bytes.
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::ptz_state_t>(b.data(), b.size(), &why));
  EXPECT_NE(why.find("fingerprint"), std::string::npos) << why;
}

TEST(MessageCheck, JpegHeaderIsReadWithoutDecoding) {
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", cv::Mat(48, 64, CV_8UC3, cv::Scalar(0, 0, 255)), jpeg);
  ptz::JpegHeader h;
  std::string why;
  ASSERT_TRUE(ptz::readJpegHeader(jpeg.data(), jpeg.size(), &h, &why)) << why;
  EXPECT_EQ(h.width, 64);
  EXPECT_EQ(h.height, 48);
  EXPECT_EQ(h.channels, 3);
  EXPECT_EQ(h.scans, 1);
  std::vector<uint8_t> progressive;
  cv::imencode(".jpg", cv::Mat(48, 64, CV_8UC3, cv::Scalar(0, 0, 255)), progressive,
               {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  ASSERT_TRUE(ptz::readJpegHeader(progressive.data(), progressive.size(), &h, &why)) << why;
  EXPECT_GT(h.scans, 1);
  EXPECT_LE(h.scans, ptz::kMaxJpegScans);
  std::vector<uint8_t> gray;
  cv::imencode(".jpg", cv::Mat(5, 7, CV_8UC1, cv::Scalar(9)), gray);
  ASSERT_TRUE(ptz::readJpegHeader(gray.data(), gray.size(), &h, &why)) << why;
  EXPECT_EQ(h.channels, 1);
  EXPECT_FALSE(ptz::readJpegHeader(jpeg.data(), 20, &h, &why));
  const std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', 0, 0, 0, 0};
  EXPECT_FALSE(ptz::readJpegHeader(png.data(), png.size(), &h, &why));
}

TEST(MessageCheck, AJpegThatClaimsAnotherSizeIsRefusedBeforeDecoding) {
  ptzstereo::image_t im = ptz::encodeImage(cv::Mat(48, 64, CV_8UC3, cv::Scalar(1, 2, 3)),
                                           ptzstereo::image_t::ENCODING_JPEG, 80);
  std::string why;
  ASSERT_TRUE(ptz::checkImage(im, ptz::kMaxImageSidePx, &why)) << why;
  // Rewrite the start-of-frame header to 30000 x 30000: the message still says 64 x 48.
  for (size_t i = 2; i + 9 < im.data.size(); ++i) {
    if (im.data[i] == 0xFF && (im.data[i + 1] == 0xC0 || im.data[i + 1] == 0xC2)) {
      im.data[i + 5] = 30000 >> 8;
      im.data[i + 6] = 30000 & 0xFF;
      im.data[i + 7] = 30000 >> 8;
      im.data[i + 8] = 30000 & 0xFF;
      break;
    }
  }
  EXPECT_FALSE(ptz::checkImage(im, ptz::kMaxImageSidePx, &why));
  EXPECT_NE(why.find("JPEG header says 30000x30000"), std::string::npos) << why;
  cv::Mat out;
  EXPECT_FALSE(ptz::decodeImage(im, &out, &why));
  EXPECT_TRUE(out.empty());
  // A decompression bomb: the last scan repeated until there are a thousand.
  im = ptz::encodeImage(cv::Mat(48, 64, CV_8UC3, cv::Scalar(1, 2, 3)),
                        ptzstereo::image_t::ENCODING_JPEG, 80);
  {
    size_t sos = 0;
    for (size_t i = 0; i + 1 < im.data.size(); ++i) {
      if (im.data[i] == 0xFF && im.data[i + 1] == 0xDA) sos = i;
    }
    const std::vector<uint8_t> scan(im.data.begin() + static_cast<ptrdiff_t>(sos),
                                    im.data.end() - 2);
    im.data.resize(im.data.size() - 2);  // without the end-of-image marker
    for (int i = 0; i < 999; ++i) im.data.insert(im.data.end(), scan.begin(), scan.end());
    im.data.push_back(0xFF);
    im.data.push_back(0xD9);
    im.data_size = static_cast<int32_t>(im.data.size());
  }
  EXPECT_FALSE(ptz::checkImage(im, ptz::kMaxImageSidePx, &why));
  EXPECT_NE(why.find("1000 scans"), std::string::npos) << why;
  // A colour JPEG in a message that says GRAY8.
  im = ptz::encodeImage(cv::Mat(48, 64, CV_8UC3), ptzstereo::image_t::ENCODING_JPEG, 80);
  im.pixel_format = ptzstereo::image_t::PIXEL_GRAY8;
  EXPECT_FALSE(ptz::checkImage(im, ptz::kMaxImageSidePx, &why));
  EXPECT_NE(why.find("channels"), std::string::npos) << why;
}

TEST(MessageCheck, BothImagesOfAFrameAreCheckedAlike) {
  ptzstereo::stereo_frame_t f = frame();
  std::string why;
  ASSERT_TRUE(ptz::checkStereoFrame(f, ptz::kMaxImageSidePx, &why)) << why;
  ASSERT_TRUE(ptz::checkFrameMatchesRig(f, 8, 6, &why)) << why;
  // The right image gray (a valid image, but not what a colour rig sees).
  f.right =
      ptz::encodeImage(cv::Mat(6, 8, CV_8UC1, cv::Scalar(5)), ptzstereo::image_t::ENCODING_RAW, 90);
  EXPECT_TRUE(ptz::checkStereoFrame(f, ptz::kMaxImageSidePx, &why)) << why;
  EXPECT_FALSE(ptz::checkFrameMatchesRig(f, 8, 6, &why));
  EXPECT_NE(why.find("right image is 8x6 gray"), std::string::npos) << why;
  f = frame();
  f.right.row_stride = 100;
  EXPECT_FALSE(ptz::checkStereoFrame(f, ptz::kMaxImageSidePx, &why));
  EXPECT_EQ(why.rfind("right image: ", 0), 0u) << why;
  f = frame();
  f.left.width = 5000;
  EXPECT_FALSE(ptz::checkStereoFrame(f, ptz::kMaxImageSidePx, &why));
  EXPECT_EQ(why.rfind("left image: size 5000x6", 0), 0u) << why;
}

TEST(MessageCheck, TracksAndTargetSelectStringsAreOneNulTerminatedString) {
  std::string why;
  // target_reason "locked": length 7, its NUL at kTargetReasonAt + 4 + 6.
  const std::vector<uint8_t> good = bytesOf(tracks(1));
  std::vector<uint8_t> t = good;
  putInt32(&t, kTargetReasonAt, 0);
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::object_tracks_t>(t.data(), t.size(), &why));
  EXPECT_NE(why.find("target_reason has length 0"), std::string::npos) << why;
  putInt32(&t, kTargetReasonAt, 1 << 30);
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::object_tracks_t>(t.data(), t.size(), &why));
  t = good;
  t[kTargetReasonAt + 4 + 6] = 'x';
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::object_tracks_t>(t.data(), t.size(), &why));
  EXPECT_NE(why.find("target_reason is not one NUL-terminated"), std::string::npos) << why;
  // The track's class_name (empty: length 1) after the count and the track's id.
  t = good;
  t[kTargetReasonAt + 4 + 7 + 4 + 8 + 4] = 'x';
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::object_tracks_t>(t.data(), t.size(), &why));
  EXPECT_NE(why.find("tracks.class_name"), std::string::npos) << why;

  ptzstereo::target_select_t select{};
  select.class_name = "box";
  const std::vector<uint8_t> s = bytesOf(select);
  std::vector<uint8_t> bad = s;
  putInt32(&bad, kSelectClassNameAt, 0);
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::target_select_t>(bad.data(), bad.size(), &why));
  putInt32(&bad, kSelectClassNameAt, 1 << 30);
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::target_select_t>(bad.data(), bad.size(), &why));
  EXPECT_NE(why.find("class_name runs past the end"), std::string::npos) << why;
  bad = s;
  bad[kSelectClassNameAt + 4 + 1] = 0;  // 'b', NUL, 'x', NUL: a NUL inside
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::target_select_t>(bad.data(), bad.size(), &why));
  EXPECT_NE(why.find("class_name is not one NUL-terminated"), std::string::npos) << why;
  ptzstereo::target_select_t back;
  EXPECT_TRUE(ptz::decodeChecked(s.data(), s.size(), &back, &why)) << why;
  EXPECT_EQ(back.class_name, "box");
}

TEST(MessageCheck, ControlStateReasonIsOneNulTerminatedString) {
  ptzstereo::control_state_t m{};
  m.reason = "coasting";
  const std::vector<uint8_t> good = bytesOf(m);
  ASSERT_EQ(good.size(), kControlReasonAt + 4 + 9);
  std::string why;
  std::vector<uint8_t> bad = good;
  putInt32(&bad, kControlReasonAt, 0);
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::control_state_t>(bad.data(), bad.size(), &why));
  EXPECT_NE(why.find("reason has length 0"), std::string::npos) << why;
  putInt32(&bad, kControlReasonAt, 1 << 30);
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::control_state_t>(bad.data(), bad.size(), &why));
  EXPECT_NE(why.find("reason runs past the end"), std::string::npos) << why;
  bad = good;
  bad[kControlReasonAt + 4 + 8] = 'x';  // the terminator
  EXPECT_FALSE(ptz::checkEncoding<ptzstereo::control_state_t>(bad.data(), bad.size(), &why));
  EXPECT_NE(why.find("reason is not one NUL-terminated"), std::string::npos) << why;
  bad = good;
  bad[kControlReasonAt + 4 + 3] = 0;  // "coa", NUL, "ting", NUL: a NUL inside
  ptzstereo::control_state_t back;
  EXPECT_FALSE(ptz::decodeChecked(bad.data(), bad.size(), &back, &why));
  EXPECT_NE(why.find("reason is not one NUL-terminated"), std::string::npos) << why;
  EXPECT_TRUE(ptz::decodeChecked(good.data(), good.size(), &back, &why)) << why;
  EXPECT_EQ(back.reason, "coasting");
}

// A preview must be a colour image of the rig's shape and no larger than it: what a viewer scales
// up to the rig's size under its overlay.
TEST(MessageCheck, APreviewIsASmallerColourImageOfTheRigsShape) {
  const auto preview = [](int w, int h, int channels) {
    ptzstereo::stereo_frame_t f{};
    f.left = f.right = ptz::encodeImage(cv::Mat(h, w, CV_8UC(channels), cv::Scalar::all(7)),
                                        ptzstereo::image_t::ENCODING_RAW, 90);
    return f;
  };
  std::string why;
  EXPECT_TRUE(ptz::checkPreviewMatchesRig(preview(320, 240, 3), 640, 480, &why)) << why;
  EXPECT_TRUE(ptz::checkPreviewMatchesRig(preview(160, 121, 3), 640, 480, &why)) << why;
  EXPECT_TRUE(ptz::checkPreviewMatchesRig(preview(640, 480, 3), 640, 480, &why)) << why;
  EXPECT_FALSE(ptz::checkPreviewMatchesRig(preview(1280, 960, 3), 640, 480, &why));
  EXPECT_NE(why.find("left preview is 1280x960 colour"), std::string::npos) << why;
  EXPECT_FALSE(ptz::checkPreviewMatchesRig(preview(320, 200, 3), 640, 480, &why));  // 16:10
  EXPECT_FALSE(ptz::checkPreviewMatchesRig(preview(8, 6, 3), 640, 480, &why));      // too small
  EXPECT_FALSE(ptz::checkPreviewMatchesRig(preview(320, 240, 1), 640, 480, &why));
  EXPECT_NE(why.find("gray"), std::string::npos) << why;
  // Hostile sizes: no overflow in the shape test.
  ptzstereo::stereo_frame_t f = preview(320, 240, 3);
  f.right.width = INT32_MAX;
  f.right.height = INT32_MAX;
  EXPECT_FALSE(ptz::checkPreviewMatchesRig(f, 640, 480, &why));
  EXPECT_NE(why.find("right preview"), std::string::npos) << why;
}
