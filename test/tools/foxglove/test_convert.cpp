// The converter on messages with known answers: images passed through or scaled with their
// calibration at the frame's zoom, the cameras' transforms against the analytic optical axis,
// detections drawn where they are, clouds repacked, tracks and statuses; hostile messages counted.
#include <glib.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/transport/transport.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/point_cloud_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "tools/foxglove/convert.hpp"

using nlohmann::json;
using ptz::foxglove::Converter;
using ptz::foxglove::ConvertOptions;
using ptz::foxglove::Message;

namespace {

template <class Msg>
std::vector<uint8_t> encode(const Msg& m) {
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

struct Converted {
  std::map<std::string, std::vector<json>> by_topic;
};

template <class Msg>
Converted convert(Converter& c, const std::string& channel, const Msg& m, int64_t receive = 1000) {
  const std::vector<uint8_t> bytes = encode(m);
  Converted out;
  for (const Message& msg : c.convert(channel, bytes.data(), bytes.size(), receive)) {
    out.by_topic[c.topics().at(static_cast<size_t>(msg.topic)).name].push_back(
        json::parse(msg.json));
  }
  return out;
}

std::string unbase64(const std::string& text) {
  gsize size = 0;
  guchar* data = g_base64_decode(text.c_str(), &size);
  std::string out(reinterpret_cast<char*>(data), size);
  g_free(data);
  return out;
}

cv::Mat pattern(int width, int height) {
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::circle(image, {width / 3, height / 2}, height / 6, cv::Scalar(0, 0, 255), -1);
  return image;
}

ptzstereo::stereo_frame_t frame(int64_t seq, int64_t utime, int8_t encoding,
                                const ptz::PtzPose& left = {0.3, -0.1, 2.5},
                                const ptz::PtzPose& right = {-0.2, 0.05, 2.5}) {
  return ptz::makeStereoFrame(utime, seq, pattern(640, 480), left, pattern(640, 480), right,
                              encoding, 90);
}

const json* transformTo(const json& tf, const std::string& child) {
  for (const json& t : tf["transforms"]) {
    if (t["child_frame_id"] == child) return &t;
  }
  return nullptr;
}

Eigen::Quaterniond quaternion(const json& q) {
  return Eigen::Quaterniond(q["w"].get<double>(), q["x"].get<double>(), q["y"].get<double>(),
                            q["z"].get<double>());
}

}  // namespace

TEST(Convert, AJpegFramePassesThroughWithItsCalibrationAtItsZoomAndTheCamerasWhereTheyPoint) {
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  Converter c(rig, {});
  const auto m = frame(7, 1'500'000'123, ptzstereo::image_t::ENCODING_JPEG);
  const Converted out = convert(c, ptz::channels::kStereoFrame, m);
  ASSERT_EQ(out.by_topic.at("/left/image").size(), 1u);
  const json& image = out.by_topic.at("/left/image")[0];
  EXPECT_EQ(image["format"], "jpeg");
  EXPECT_EQ(image["frame_id"], "left_camera");
  EXPECT_EQ(image["timestamp"]["sec"], 1500);
  EXPECT_EQ(image["timestamp"]["nsec"], 123000);
  EXPECT_EQ(unbase64(image["data"]), std::string(m.left.data.begin(), m.left.data.end()));

  const json& info = out.by_topic.at("/left/camera_info")[0];
  const ptz::Intrinsics in = rig.left.intrinsicsAt(2.5);
  EXPECT_EQ(info["width"], 640);
  EXPECT_EQ(info["distortion_model"], "plumb_bob");
  EXPECT_DOUBLE_EQ(info["K"][0].get<double>(), in.fx);
  EXPECT_DOUBLE_EQ(info["K"][2].get<double>(), in.cx);
  EXPECT_DOUBLE_EQ(info["K"][4].get<double>(), in.fy);
  EXPECT_DOUBLE_EQ(info["K"][5].get<double>(), in.cy);
  EXPECT_DOUBLE_EQ(info["P"][0].get<double>(), in.fx);
  EXPECT_DOUBLE_EQ(info["P"][3].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(info["D"][0].get<double>(), in.distortion[0]);
  // Zoomed in, the focal length is longer than at 1x.
  EXPECT_GT(in.fx, rig.left.intrinsicsAt(1).fx * 2);

  // The left camera's optical axis in the head frame at pan p, tilt t (positive tilt looks up,
  // -y): (sin p cos t, -sin t, cos p cos t), the head's axes being the left camera's at home.
  const json* left = transformTo(out.by_topic.at("/tf")[0], "left_camera");
  ASSERT_NE(left, nullptr);
  EXPECT_EQ((*left)["parent_frame_id"], "head");
  const Eigen::Vector3d axis = quaternion((*left)["rotation"]) * Eigen::Vector3d::UnitZ();
  const double p = 0.3, t = -0.1;
  EXPECT_NEAR(axis.x(), std::sin(p) * std::cos(t), 1e-9);
  EXPECT_NEAR(axis.y(), -std::sin(t), 1e-9);
  EXPECT_NEAR(axis.z(), std::cos(p) * std::cos(t), 1e-9);
  // The right camera sits a baseline away.
  const json* right = transformTo(out.by_topic.at("/tf")[0], "right_camera");
  ASSERT_NE(right, nullptr);
  const Eigen::Vector3d l((*left)["translation"]["x"], (*left)["translation"]["y"],
                          (*left)["translation"]["z"]);
  const Eigen::Vector3d r((*right)["translation"]["x"], (*right)["translation"]["y"],
                          (*right)["translation"]["z"]);
  EXPECT_NEAR((r - l).norm(), rig.baselineM(), 0.02);
  // The world frame has z up: the head's forward (+z) is world +x, its down (+y) world -z.
  const json* head = transformTo(out.by_topic.at("/tf")[0], "head");
  ASSERT_NE(head, nullptr);
  EXPECT_EQ((*head)["parent_frame_id"], "world");
  const Eigen::Quaterniond world_head = quaternion((*head)["rotation"]);
  EXPECT_TRUE((world_head * Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitX(), 1e-12));
  EXPECT_TRUE((world_head * Eigen::Vector3d::UnitY()).isApprox(-Eigen::Vector3d::UnitZ(), 1e-12));
}

TEST(Convert, ARawFrameIsScaledToTheMaximumWidthWithItsCalibrationAndDetectionsAlike) {
  const ptz::StereoRig rig = ptz::StereoRig::makeDefault();
  ConvertOptions options;
  options.image_max_width_px = 320;
  Converter c(rig, options);
  const auto m = frame(3, 2'000'000, ptzstereo::image_t::ENCODING_RAW);
  const Converted out = convert(c, ptz::channels::kStereoFrame, m);
  const std::string jpeg = unbase64(out.by_topic.at("/right/image")[0]["data"]);
  const cv::Mat decoded =
      cv::imdecode(std::vector<uchar>(jpeg.begin(), jpeg.end()), cv::IMREAD_COLOR);
  ASSERT_EQ(decoded.cols, 320);
  ASSERT_EQ(decoded.rows, 240);
  // The red disc stays where it was, at half the coordinates.
  const cv::Vec3b centre = decoded.at<cv::Vec3b>(120, 320 / 3);
  EXPECT_GT(centre[2], 200);
  EXPECT_LT(centre[0], 60);
  const json& info = out.by_topic.at("/right/camera_info")[0];
  EXPECT_EQ(info["width"], 320);
  EXPECT_NEAR(info["K"][0].get<double>(), rig.right.intrinsicsAt(2.5).fx / 2, 1e-9);
  EXPECT_NEAR(info["K"][5].get<double>(), rig.right.intrinsicsAt(2.5).cy / 2, 1e-9);

  ptzstereo::object_detections_t d{};
  d.utime = m.utime;
  d.frame_seq = 3;
  d.left.push_back({"red_ball", 213.0, 240.0, 5000, 180, 200, 66, 80, 0.01, 0});
  d.num_left = 1;
  const Converted drawn = convert(c, ptz::channels::kObjectDetections, d);
  const json& left = drawn.by_topic.at("/left/detections")[0];
  ASSERT_EQ(left["circles"].size(), 1u);
  EXPECT_DOUBLE_EQ(left["circles"][0]["position"]["x"].get<double>(), 106.5);
  EXPECT_DOUBLE_EQ(left["circles"][0]["position"]["y"].get<double>(), 120.0);
  EXPECT_DOUBLE_EQ(left["points"][0]["points"][2]["x"].get<double>(), (180 + 66) / 2.0);
  EXPECT_EQ(left["texts"][0]["text"], "red_ball");
  EXPECT_TRUE(drawn.by_topic.at("/right/detections")[0]["circles"].empty());
  // Detections of a frame whose images were not converted are not drawn.
  d.frame_seq = 99;
  EXPECT_EQ(convert(c, ptz::channels::kObjectDetections, d).by_topic.count("/left/detections"), 0u);
}

TEST(Convert, AnImageRateKeepsEveryThirdFrameOf30HzAt10HzAndTransformsOfAll) {
  ConvertOptions options;
  options.image_rate_hz = 10;
  Converter c(ptz::StereoRig::makeDefault(), options);
  int images = 0, transforms = 0;
  for (int seq = 0; seq < 30; ++seq) {
    const auto m = frame(seq, 1'000'000 + seq * 33'333, ptzstereo::image_t::ENCODING_JPEG);
    const Converted out = convert(c, ptz::channels::kStereoFrame, m);
    images += static_cast<int>(out.by_topic.count("/left/image"));
    transforms += static_cast<int>(out.by_topic.count("/tf"));
  }
  EXPECT_EQ(images, 10);
  EXPECT_EQ(transforms, 30);
}

TEST(Convert, APaddedCloudIsRepackedAndAnInconsistentOneIsDroppedAndCounted) {
  Converter c(ptz::StereoRig::makeDefault(), {});
  ptzstereo::point_cloud_t cloud{};
  cloud.utime = 5'000'000;
  cloud.frame_id = "head";
  cloud.width = 2;
  cloud.height = 2;
  cloud.point_step = 16;
  cloud.row_step = 40;  // 8 bytes of padding per row
  cloud.fields = {{"x", 0, 7, 1}, {"y", 4, 7, 1}, {"z", 8, 7, 1}, {"rgb", 12, 7, 1}};
  cloud.num_fields = 4;
  cloud.data.assign(80, 0);
  for (int i = 0; i < 80; ++i) cloud.data[static_cast<size_t>(i)] = static_cast<uint8_t>(i);
  cloud.data_size = 80;
  const Converted out = convert(c, ptz::channels::kPointCloud, cloud);
  const json& j = out.by_topic.at("/cloud")[0];
  EXPECT_EQ(j["frame_id"], "head");
  EXPECT_EQ(j["point_stride"], 16);
  EXPECT_EQ(j["fields"][0]["type"], 7);  // FLOAT32
  EXPECT_EQ(j["fields"][3]["type"], 5);  // a PCL colour: UINT32, read as packed BGR
  const std::string data = unbase64(j["data"]);
  ASSERT_EQ(data.size(), 64u);
  EXPECT_EQ(static_cast<uint8_t>(data[32]), 40);  // the second row starts after its padding
  EXPECT_EQ(static_cast<uint8_t>(data[63]), 71);

  cloud.fields[3].offset = 14;  // a float that would run past the point
  EXPECT_TRUE(convert(c, ptz::channels::kPointCloud, cloud).by_topic.empty());
  EXPECT_EQ(c.dropped().at("POINT_CLOUD: inconsistent cloud"), 1);
}

TEST(Convert, TracksAreDrawnWithTheTargetMarkedAndWhatIsNotANumberLeftOut) {
  Converter c(ptz::StereoRig::makeDefault(), {});
  ptzstereo::object_tracks_t m{};
  m.utime = 3'000'000;
  m.target_id = 4;
  m.tracks.resize(3);
  m.tracks[0].id = 4;
  m.tracks[0].class_name = "red_ball";
  m.tracks[0].state = ptzstereo::object_track_t::STATE_CONFIRMED;
  m.tracks[0].position_m[0] = 0.1;
  m.tracks[0].position_m[2] = 2.0;
  m.tracks[0].radius_m = 0.05;
  m.tracks[1].id = 5;
  m.tracks[1].class_name = "box";
  m.tracks[1].has_orientation = true;
  m.tracks[1].orientation_wxyz[0] = 1;
  m.tracks[1].position_m[2] = 3.0;
  m.tracks[2].id = 6;
  m.tracks[2].position_m[0] = NAN;
  m.num_tracks = 3;
  const Converted out = convert(c, ptz::channels::kObjectTracks, m);
  const json& scene = out.by_topic.at("/objects")[0];
  EXPECT_EQ(scene["deletions"][0]["type"], 1);  // all of the previous frame's
  ASSERT_EQ(scene["entities"].size(), 2u);
  const json& target = scene["entities"][0];
  EXPECT_EQ(target["id"], "track-4");
  EXPECT_EQ(target["frame_id"], "head");
  EXPECT_DOUBLE_EQ(target["spheres"][0]["size"]["x"].get<double>(), 0.1);
  EXPECT_DOUBLE_EQ(target["spheres"][0]["pose"]["position"]["z"].get<double>(), 2.0);
  EXPECT_EQ(target["texts"][0]["text"], "4 red_ball (target)");
  EXPECT_GT(target["spheres"][0]["color"]["r"].get<double>(), 0.9);
  EXPECT_EQ(scene["entities"][1]["cubes"].size(), 1u);  // an object with an orientation
  // ... and its axes: x, y, z as arrows along their pose's x, from its centre.
  const json& arrows = scene["entities"][1]["arrows"];
  ASSERT_EQ(arrows.size(), 3u);
  EXPECT_TRUE(target["arrows"].empty());
  const Eigen::Vector3d along[3] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                    Eigen::Vector3d::UnitZ()};
  for (size_t k = 0; k < 3; ++k) {
    const json& q = arrows[k]["pose"]["orientation"];
    const Eigen::Quaterniond qe(q["w"].get<double>(), q["x"].get<double>(), q["y"].get<double>(),
                                q["z"].get<double>());
    EXPECT_LT((qe * Eigen::Vector3d::UnitX() - along[k]).norm(), 1e-9) << k;
    EXPECT_DOUBLE_EQ(arrows[k]["pose"]["position"]["z"].get<double>(), 3.0);
  }
  EXPECT_GT(arrows[0]["color"]["r"].get<double>(), 0.9);
  EXPECT_GT(arrows[2]["color"]["b"].get<double>(), 0.9);
  // The raw message keeps the track that is not a number, as null.
  const json& raw = out.by_topic.at("/object_tracks")[0];
  ASSERT_EQ(raw["tracks"].size(), 3u);
  EXPECT_TRUE(raw["tracks"][2]["position_m"][0].is_null());
}

TEST(Convert, StatusesGetATopicPerProcessKeyedByNameAndAreBoundedInNumber) {
  Converter c(ptz::StereoRig::makeDefault(), {});
  ptzstereo::process_status_t s{};
  s.utime = 1;
  s.process = "ptz-sim";
  s.counters = {{"frames_published", 42}};
  s.num_counters = 1;
  s.channels = {{"STEREO_FRAME", ptzstereo::channel_status_t::DIRECTION_OUT, 30, 100, 0, 1, 2}};
  s.num_channels = 1;
  const Converted out = convert(c, "PROCESS_STATUS_ptz-sim", s);
  const json& j = out.by_topic.at("/status/ptz-sim")[0];
  EXPECT_EQ(j["counters"]["frames_published"], 42);
  EXPECT_EQ(j["channels"]["STEREO_FRAME.out"]["rate_hz"], 30.0);
  EXPECT_EQ(j["state_name"], "OK");
  s.process = "a/b\n{evil}";
  EXPECT_EQ(convert(c, "PROCESS_STATUS_x", s).by_topic.count("/status/a_b__evil_"), 1u);
  const size_t before = c.topics().size();
  for (int i = 0; i < 200; ++i) {
    s.process = "p" + std::to_string(i);
    convert(c, "PROCESS_STATUS_" + s.process, s);
  }
  EXPECT_EQ(c.topics().size() - before, 64u - 2u);  // 64 status topics in all
  EXPECT_EQ(c.dropped().at("PROCESS_STATUS_p199: too many processes"), 1);
}

TEST(Convert, HostileBytesAreCountedAndConvertToNothing) {
  Converter c(ptz::StereoRig::makeDefault(), {});
  const auto m = frame(1, 1'000'000, ptzstereo::image_t::ENCODING_JPEG);
  std::vector<uint8_t> bytes = encode(m);
  // Cut, and a count that claims more than the bytes hold.
  EXPECT_TRUE(c.convert(ptz::channels::kStereoFrame, bytes.data(), bytes.size() / 2, 1).empty());
  EXPECT_TRUE(c.convert(ptz::channels::kPtzState, bytes.data(), 12, 1).empty());
  EXPECT_TRUE(c.convert("PROCESS_STATUS_x", nullptr, 0, 1).empty());
  EXPECT_EQ(c.dropped().at("STEREO_FRAME: undecodable"), 1);
  EXPECT_EQ(c.dropped().at("PTZ_STATE: undecodable"), 1);
  EXPECT_EQ(c.dropped().at("PROCESS_STATUS_x: undecodable"), 1);
  // A JPEG whose header says another size than the message.
  auto lying = m;
  lying.left.width = 320;
  lying.right.width = 320;
  const Converted none = convert(c, ptz::channels::kStereoFrame, lying);
  EXPECT_EQ(none.by_topic.count("/left/image"), 0u);
  EXPECT_EQ(c.dropped().at("STEREO_FRAME: bad image"), 1);
  // Channels it does not show, bounded in number.
  for (int i = 0; i < 1000; ++i) c.convert("NOISE_" + std::to_string(i), bytes.data(), 8, 1);
  EXPECT_LE(c.ignored().size(), 257u);
  EXPECT_GT(c.ignored().at("(other channels)"), 0);
}

TEST(Convert, WithAChannelPrefixOnlyThePrefixedChannelsAreShown) {
  ConvertOptions options;
  options.channel_prefix = "SIM_";
  Converter c(ptz::StereoRig::makeDefault(), options);
  ptzstereo::ptz_setpoint_t m{};
  m.utime = 9;
  EXPECT_EQ(convert(c, "SIM_PTZ_SETPOINT", m).by_topic.count("/ptz_setpoint"), 1u);
  EXPECT_TRUE(convert(c, "PTZ_SETPOINT", m).by_topic.empty());
  EXPECT_EQ(c.ignored().at("PTZ_SETPOINT"), 1);
}

// fuzz_foxglove_convert's find: LCM strings are any bytes, and nlohmann's dump() threw on bytes
// that are not UTF-8, out of ptz-mcap and the bridge.
TEST(Convert, StringsThatAreNotUtf8ConvertToValidJson) {
  Converter c(ptz::StereoRig::makeDefault(), {});
  ptzstereo::object_tracks_t m{};
  m.utime = 5;
  m.tracks.resize(1);
  m.num_tracks = 1;
  m.tracks[0].class_name = "ball\xff\xfe(";
  const Converted out = convert(c, ptz::channels::kObjectTracks, m);
  ASSERT_EQ(out.by_topic.count("/object_tracks"), 1u);
  EXPECT_EQ(out.by_topic.at("/object_tracks")[0]["tracks"][0]["class_name"],
            "ball\xef\xbf\xbd\xef\xbf\xbd(");  // each bad byte one U+FFFD
  ptzstereo::process_status_t s{};
  s.process = "p\xc3";
  s.hostname = "h";
  s.message = "\x80";
  EXPECT_EQ(convert(c, "PROCESS_STATUS_P", s).by_topic.size(), 1u);
}
