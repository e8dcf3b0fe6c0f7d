#include "tools/foxglove/convert.hpp"

#include <glib.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <deque>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "common/measure.hpp"
#include "common/transport/message_check.hpp"
#include "common/transport/transport.hpp"
#include "ptzstereo/point_cloud_t.hpp"
#include "tools/foxglove/foxglove_schemas.hpp"
#include "tools/foxglove/lcm_json.hpp"

namespace ptz::foxglove {
namespace {

using nlohmann::json;

json stamp(int64_t utime) {
  const int64_t t = std::max<int64_t>(utime, 0);
  return {{"sec", t / 1'000'000}, {"nsec", (t % 1'000'000) * 1000}};
}
json vec3(const Eigen::Vector3d& v) {
  return {{"x", v.x()}, {"y", v.y()}, {"z", v.z()}};
}
json quat(const Eigen::Quaterniond& q) {
  return {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}};
}
json rgba(double r, double g, double b, double a) {
  return {{"r", r}, {"g", g}, {"b", b}, {"a", a}};
}
json point2(double x, double y) {
  return {{"x", x}, {"y", y}};
}

// The most characters g_base64_encode_step and g_base64_encode_close write for size bytes.
constexpr size_t base64MaxChars(size_t size) {
  return (size / 3 + 1) * 4 + 4;
}

// Appends the base64 of size bytes to text, encoded in place (no intermediate copy).
void appendBase64(std::string* text, const void* data, size_t size) {
  const size_t at = text->size();
  text->resize(at + base64MaxChars(size));
  gint state = 0, save = 0;
  char* out = text->data() + at;
  gsize n = g_base64_encode_step(static_cast<const guchar*>(data), size, FALSE, out, &state, &save);
  n += g_base64_encode_close(FALSE, out + n, &state, &save);
  text->resize(at + n);
}

// j.dump() with the bytes, base64, as j["data"]. The base64 is written straight into the text:
// the serializer's escaping would walk every character of the message's largest field, where
// base64 has nothing to escape. "data" is the first of j's keys (they are sorted).
std::string dumpWithBase64Data(json j, const void* data, size_t size) {
  j["data"] = "";
  const std::string without = dumpJson(j);
  constexpr char kHead[] = R"({"data":")";
  constexpr size_t kHeadChars = sizeof kHead - 1;
  if (without.compare(0, kHeadChars + 1, R"({"data":"")") != 0) {
    throw std::logic_error("dumpWithBase64Data: \"data\" is not the first key of " + without);
  }
  std::string text;
  text.reserve(without.size() + base64MaxChars(size));
  text.append(without, 0, kHeadChars);
  appendBase64(&text, data, size);
  text.append(without, kHeadChars, std::string::npos);
  return text;
}

// The world frame of the 3D view: z up, x forward (the head's home optical axis), y left.
Eigen::Quaterniond worldFromHead() {
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(0, -1, 0);  // head x (right)
  r.col(1) = Eigen::Vector3d(0, 0, -1);  // head y (down)
  r.col(2) = Eigen::Vector3d(1, 0, 0);   // head z (forward)
  return Eigen::Quaterniond(r);
}

const char* const kSides[] = {"left", "right"};
constexpr size_t kMaxStatusTopics = 64;
constexpr size_t kMaxCountKeys = 256;
constexpr size_t kShownFrames = 64;  // frames whose images were converted, for their annotations

}  // namespace

struct Converter::Impl {
  StereoRig rig;
  ConvertOptions options;
  std::vector<Topic> topics;
  std::map<std::string, int> topic_index;
  RateSchedule image_schedule, preview_schedule, cloud_schedule;
  // seq -> output width / frame width of the images converted, per side.
  std::deque<std::pair<int64_t, std::array<double, 2>>> shown;
  std::map<std::string, int64_t> dropped, converted, ignored, decoded;
  // The topics each channel (without the prefix) makes; status channels make their own.
  std::map<std::string, std::vector<std::string>> channel_topics;
  const TopicFilter* wanted = nullptr;  // during convert(); null: every topic
  int64_t images_converted = 0, not_wanted = 0;

  Impl(StereoRig r, ConvertOptions o)
      : rig(std::move(r)),
        options(o),
        image_schedule(o.image_rate_hz),
        preview_schedule(o.image_rate_hz),
        cloud_schedule(o.cloud_rate_hz) {
    for (const char* side : kSides) {
      const std::string s = std::string("/") + side;
      addFoxglove(s + "/image", "foxglove.CompressedImage");
      addFoxglove(s + "/camera_info", "foxglove.CameraCalibration");
      addFoxglove(s + "/detections", "foxglove.ImageAnnotations");
      addFoxglove("/preview" + s + "/image", "foxglove.CompressedImage");
      addFoxglove("/preview" + s + "/camera_info", "foxglove.CameraCalibration");
    }
    addFoxglove("/tf", "foxglove.FrameTransforms");
    addFoxglove("/cloud", "foxglove.PointCloud");
    addFoxglove("/cloud_preview", "foxglove.PointCloud");
    addFoxglove("/objects", "foxglove.SceneUpdate");
    addFoxglove("/truth", "foxglove.SceneUpdate");
    addOwn("/ptz_state", "ptzstereo.ptz_state_t", toJson(ptzstereo::ptz_state_t{}));
    addOwn("/ptz_setpoint", "ptzstereo.ptz_setpoint_t", toJson(ptzstereo::ptz_setpoint_t{}));
    addOwn("/control_state", "ptzstereo.control_state_t", toJson(ptzstereo::control_state_t{}));
    ptzstereo::object_detections_t detections{};
    detections.left.resize(1);
    addOwn("/object_detections", "ptzstereo.object_detections_t", toJson(detections));
    ptzstereo::object_pose_t pose{};
    pose.objects.resize(1);
    addOwn("/object_pose", "ptzstereo.object_pose_t", toJson(pose));
    ptzstereo::object_tracks_t tracks{};
    tracks.tracks.resize(1);
    addOwn("/object_tracks", "ptzstereo.object_tracks_t", toJson(tracks));
    ptzstereo::sim_truth_t truth{};
    truth.objects.resize(1);
    addOwn("/sim_truth", "ptzstereo.sim_truth_t", toJson(truth));
    addOwn("/target_select", "ptzstereo.target_select_t", toJson(ptzstereo::target_select_t{}));
    namespace ch = channels;
    for (const char* frames : {ch::kStereoFrame, ch::kStereoPreview}) {
      const std::string p = frames == ch::kStereoFrame ? "/" : "/preview/";
      channel_topics[frames] = {"/tf", p + "left/image", p + "left/camera_info", p + "right/image",
                                p + "right/camera_info"};
    }
    channel_topics[ch::kPtzState] = {"/ptz_state", "/tf"};
    channel_topics[ch::kPtzSetpoint] = {"/ptz_setpoint"};
    channel_topics[ch::kControlState] = {"/control_state"};
    channel_topics[ch::kObjectDetections] = {"/object_detections", "/left/detections",
                                             "/right/detections"};
    channel_topics[ch::kObjectPose] = {"/object_pose"};
    channel_topics[ch::kObjectTracks] = {"/object_tracks", "/objects"};
    channel_topics[ch::kSimTruth] = {"/sim_truth", "/truth"};
    channel_topics[ch::kTargetSelect] = {"/target_select"};
    channel_topics[ch::kPointCloud] = {"/cloud"};
    channel_topics[ch::kPointCloudPreview] = {"/cloud_preview"};
  }

  bool want(const std::string& topic_name) const {
    return !wanted || !*wanted || (*wanted)(topic(topic_name));
  }
  // Whether any topic the channel makes is wanted (a channel not listed: yes).
  bool wantAny(const std::string& channel) const {
    const auto it = channel_topics.find(channel);
    if (it == channel_topics.end()) return true;
    return std::any_of(it->second.begin(), it->second.end(),
                       [this](const std::string& t) { return want(t); });
  }

  int addTopic(const std::string& name, const std::string& schema_name, const json& schema) {
    topics.push_back({name, schema_name, dumpJson(schema)});
    topic_index[name] = static_cast<int>(topics.size()) - 1;
    return topic_index[name];
  }
  void addFoxglove(const std::string& name, const std::string& schema_name) {
    addTopic(name, schema_name, foxgloveSchema(schema_name));
  }
  void addOwn(const std::string& name, const std::string& schema_name, const json& sample) {
    addTopic(name, schema_name, schemaOf(sample, schema_name));
  }
  int topic(const std::string& name) const { return topic_index.at(name); }

  Message message(const std::string& name, int64_t receive_utime, int64_t data_utime,
                  const json& j) const {
    return textMessage(name, receive_utime, data_utime, dumpJson(j));
  }
  Message textMessage(const std::string& name, int64_t receive_utime, int64_t data_utime,
                      std::string json_text) const {
    return {topic(name), utimeToNs(receive_utime), utimeToNs(data_utime), std::move(json_text)};
  }

  template <class Msg>
  bool decode(const std::string& channel, const void* data, size_t size, Msg* msg) {
    std::string why;
    if (decodeChecked(data, size, msg, &why)) {
      countIn(&decoded, printable(channel, 80));
      return true;
    }
    countDrop(channel, "undecodable");
    return false;
  }

  // Channel names come from outside: a bounded number of keys.
  static void countIn(std::map<std::string, int64_t>* counts, const std::string& key) {
    if (counts->size() >= kMaxCountKeys && !counts->count(key)) {
      ++(*counts)["(other channels)"];
    } else {
      ++(*counts)[key];
    }
  }
  void countDrop(const std::string& channel, const std::string& reason) {
    countIn(&dropped, printable(channel, 80) + ": " + reason);
  }

  json cameraTransform(Side side, int64_t utime, double pan_rad, double tilt_rad) const {
    Eigen::Matrix3d rotation;
    Eigen::Vector3d position;
    rig.cameraPose(side, pan_rad, tilt_rad, &rotation, &position);
    return {{"timestamp", stamp(utime)},
            {"parent_frame_id", "head"},
            {"child_frame_id", std::string(sideName(side)) + "_camera"},
            {"translation", vec3(position)},
            {"rotation", quat(Eigen::Quaterniond(rotation).normalized())}};
  }

  json transforms(int64_t utime, const double (&pan_tilt)[2][2]) const {
    json world = {{"timestamp", stamp(utime)},
                  {"parent_frame_id", "world"},
                  {"child_frame_id", "head"},
                  {"translation", vec3(Eigen::Vector3d::Zero())},
                  {"rotation", quat(worldFromHead())}};
    return {
        {"transforms",
         json::array({world, cameraTransform(Side::kLeft, utime, pan_tilt[0][0], pan_tilt[0][1]),
                      cameraTransform(Side::kRight, utime, pan_tilt[1][0], pan_tilt[1][1])})}};
  }

  json calibration(Side side, int64_t utime, double zoom, int width, int height) const {
    const CameraSpec& cam = rig.camera(side);
    const Intrinsics in = cam.intrinsicsAt(zoom);
    const double sx = static_cast<double>(width) / cam.width;
    const double sy = static_cast<double>(height) / cam.height;
    const double fx = in.fx * sx, fy = in.fy * sy, cx = in.cx * sx, cy = in.cy * sy;
    json d = json::array();
    for (double k : in.distortion) d.push_back(k);
    return {{"timestamp", stamp(utime)},
            {"frame_id", std::string(sideName(side)) + "_camera"},
            {"width", width},
            {"height", height},
            {"distortion_model", "plumb_bob"},
            {"D", d},
            {"K", {fx, 0, cx, 0, fy, cy, 0, 0, 1}},
            {"R", {1, 0, 0, 0, 1, 0, 0, 0, 1}},
            {"P", {fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0}}};
  }

  // The image as JPEG of at most max_width_px: its own bytes, or *encoded; its width ratio in
  // *scale. Null: undecodable.
  const std::vector<uint8_t>* jpegOf(const ptzstereo::image_t& image, std::vector<uint8_t>* encoded,
                                     double* scale, int* width, int* height) const {
    const int max_width = options.image_max_width_px;
    *scale = 1;
    *width = image.width;
    *height = image.height;
    if (image.encoding == ptzstereo::image_t::ENCODING_JPEG &&
        (max_width <= 0 || image.width <= max_width)) {
      return &image.data;
    }
    cv::Mat pixels;
    std::string error;
    if (!decodeImage(image, &pixels, &error)) return nullptr;
    if (max_width > 0 && pixels.cols > max_width) {
      *scale = static_cast<double>(max_width) / pixels.cols;
      *width = max_width;
      *height = std::max(1, static_cast<int>(std::lround(pixels.rows * *scale)));
      cv::resize(pixels, pixels, cv::Size(*width, *height), 0, 0, cv::INTER_AREA);
    }
    if (!cv::imencode(".jpg", pixels, *encoded, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality})) {
      return nullptr;
    }
    return encoded;
  }

  void frame(const std::string& channel, const ptzstereo::stereo_frame_t& m, int64_t receive_utime,
             bool preview, std::vector<Message>* out) {
    std::string why;
    if (!checkStereoFrame(m, kMaxImageSidePx, &why)) {
      countDrop(channel, "bad image");
      return;
    }
    const double pan_tilt[2][2] = {{m.left.pan_rad, m.left.tilt_rad},
                                   {m.right.pan_rad, m.right.tilt_rad}};
    if (want("/tf")) {
      out->push_back(message("/tf", receive_utime, m.utime, transforms(m.utime, pan_tilt)));
    }
    const std::string prefix = preview ? "/preview/" : "/";
    const auto wantSide = [&](int i) {
      return want(prefix + kSides[i] + "/image") || want(prefix + kSides[i] + "/camera_info");
    };
    if (!wantSide(0) && !wantSide(1)) return;  // no image decoded, scaled or encoded
    RateSchedule& schedule = preview ? preview_schedule : image_schedule;
    if (schedule.enabled() && !schedule.take(m.utime)) return;
    std::array<double, 2> scales{1, 1};
    for (int i = 0; i < 2; ++i) {
      if (!wantSide(i)) continue;
      const Side side = static_cast<Side>(i);
      const ptzstereo::image_t& image = i == 0 ? m.left : m.right;
      std::vector<uint8_t> encoded;
      int width = 0, height = 0;
      const std::vector<uint8_t>* jpeg = jpegOf(image, &encoded, &scales[i], &width, &height);
      if (!jpeg) {
        countDrop(channel, "undecodable image");
        return;
      }
      const std::string s = prefix + kSides[i];
      const json others = {{"timestamp", stamp(m.utime)},
                           {"frame_id", std::string(kSides[i]) + "_camera"},
                           {"format", "jpeg"}};
      if (want(s + "/image")) {
        out->push_back(textMessage(s + "/image", receive_utime, m.utime,
                                   dumpWithBase64Data(others, jpeg->data(), jpeg->size())));
        ++images_converted;
      }
      // A preview is smaller than the rig's images: its calibration is scaled to it.
      if (want(s + "/camera_info")) {
        out->push_back(message(s + "/camera_info", receive_utime, m.utime,
                               calibration(side, m.utime, image.zoom, width, height)));
      }
    }
    if (!preview) {
      // Detections are in the frame's pixels; they are drawn on the image as converted.
      shown.emplace_back(m.seq, scales);
      if (shown.size() > kShownFrames) shown.pop_front();
    }
  }

  void detections(const ptzstereo::object_detections_t& m, int64_t receive_utime,
                  std::vector<Message>* out) const {
    const auto it = std::find_if(shown.begin(), shown.end(),
                                 [&](const auto& s) { return s.first == m.frame_seq; });
    if (it == shown.end()) return;  // its frame's images were not converted (decimated)
    for (int i = 0; i < 2; ++i) {
      const double k = it->second[i];
      json a = {{"circles", json::array()}, {"points", json::array()}, {"texts", json::array()}};
      for (const auto& d : i == 0 ? m.left : m.right) {
        if (!std::isfinite(d.centroid_x_px) || !std::isfinite(d.centroid_y_px)) continue;
        const json colour = d.match_index >= 0 ? rgba(1, 0, 1, 1) : rgba(1, 1, 0, 1);
        const double x0 = d.bbox_x_px * k, y0 = d.bbox_y_px * k;
        const double x1 = x0 + d.bbox_width_px * k, y1 = y0 + d.bbox_height_px * k;
        a["points"].push_back({{"timestamp", stamp(m.utime)},
                               {"type", fg::kPointsLineLoop},
                               {"points", json::array({point2(x0, y0), point2(x1, y0),
                                                       point2(x1, y1), point2(x0, y1)})},
                               {"outline_color", colour},
                               {"outline_colors", json::array()},
                               {"fill_color", rgba(0, 0, 0, 0)},
                               {"thickness", 2}});
        a["circles"].push_back({{"timestamp", stamp(m.utime)},
                                {"position", point2(d.centroid_x_px * k, d.centroid_y_px * k)},
                                {"diameter", 6},
                                {"thickness", 2},
                                {"fill_color", colour},
                                {"outline_color", colour}});
        a["texts"].push_back({{"timestamp", stamp(m.utime)},
                              {"position", point2(x0, std::max(0.0, y0 - 4))},
                              {"text", printable(d.class_name, 40)},
                              {"font_size", 14},
                              {"text_color", colour},
                              {"background_color", rgba(0, 0, 0, 0.5)}});
      }
      out->push_back(
          message(std::string("/") + kSides[i] + "/detections", receive_utime, m.utime, a));
    }
  }

  // A foxglove.PointCloud of a POINT_CLOUD (PCL's layout), rows packed, as JSON text. False:
  // inconsistent.
  bool cloud(const ptzstereo::point_cloud_t& m, std::string* json_text) const {
    if (m.width < 0 || m.height < 0 || m.point_step <= 0 || m.row_step < 0 || m.is_bigendian) {
      return false;
    }
    const int64_t points = static_cast<int64_t>(m.width) * m.height;
    if (static_cast<int64_t>(m.width) * m.point_step > m.row_step && m.height > 0) return false;
    if (static_cast<int64_t>(m.row_step) * m.height > static_cast<int64_t>(m.data.size())) {
      return false;
    }
    json fields = json::array();
    for (const auto& f : m.fields) {
      static const int kSize[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
      static const int kType[] = {0,          fg::kInt8,   fg::kUint8,   fg::kInt16,  fg::kUint16,
                                  fg::kInt32, fg::kUint32, fg::kFloat32, fg::kFloat64};
      if (f.datatype < 1 || f.datatype > 8 || f.offset < 0 || f.count < 1 ||
          static_cast<int64_t>(f.offset) + int64_t{kSize[f.datatype]} * f.count > m.point_step) {
        return false;
      }
      // PCL packs a colour into a float's bits (0x00RRGGBB): Foxglove reads it as a packed BGR.
      const int type = f.name == "rgb" && f.datatype == 7 ? fg::kUint32 : kType[f.datatype];
      fields.push_back({{"name", printable(f.name, 40)}, {"offset", f.offset}, {"type", type}});
    }
    // Rows without padding between them (PCL's usual layout) are packed already.
    const size_t row_bytes = static_cast<size_t>(m.width) * m.point_step;
    const void* data = m.data.data();
    std::string packed;
    if (static_cast<size_t>(m.row_step) != row_bytes) {
      packed.reserve(static_cast<size_t>(points * m.point_step));
      for (int32_t row = 0; row < m.height; ++row) {
        const auto* begin = m.data.data() + static_cast<size_t>(row) * m.row_step;
        packed.append(reinterpret_cast<const char*>(begin), row_bytes);
      }
      data = packed.data();
    }
    const json others = {{"timestamp", stamp(m.utime)},
                         {"frame_id", "head"},
                         {"pose",
                          {{"position", vec3(Eigen::Vector3d::Zero())},
                           {"orientation", quat(Eigen::Quaterniond::Identity())}}},
                         {"point_stride", m.point_step},
                         {"fields", fields}};
    *json_text = dumpWithBase64Data(others, data, static_cast<size_t>(points * m.point_step));
    return true;
  }

  static json entity(const std::string& id, int64_t utime, const Eigen::Vector3d& position,
                     double radius_m, const Eigen::Quaterniond* orientation, const json& colour,
                     const std::string& label) {
    const json pose = {
        {"position", vec3(position)},
        {"orientation", quat(orientation ? *orientation : Eigen::Quaterniond::Identity())}};
    const double size = std::isfinite(radius_m) && radius_m > 0 ? 2 * radius_m : 0.05;
    const json shape = {
        {"pose", pose}, {"size", vec3(Eigen::Vector3d::Constant(size))}, {"color", colour}};
    const json label_pose = {{"position", vec3(position - Eigen::Vector3d(0, size, 0))},
                             {"orientation", quat(Eigen::Quaterniond::Identity())}};
    // An object with an orientation shows its axes: x red, y green, z blue (an arrow points along
    // its pose's x).
    json arrows = json::array();
    if (orientation) {
      const double length = std::max(size, 0.1);
      const Eigen::Quaterniond to_axis[3] = {
          Eigen::Quaterniond::Identity(),
          Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())),
          Eigen::Quaterniond(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()))};
      const json colours[3] = {rgba(1, 0, 0, 1), rgba(0, 1, 0, 1), rgba(0, 0, 1, 1)};
      for (int k = 0; k < 3; ++k) {
        arrows.push_back(
            {{"pose",
              {{"position", vec3(position)}, {"orientation", quat(*orientation * to_axis[k])}}},
             {"shaft_length", 0.8 * length},
             {"shaft_diameter", 0.05 * length},
             {"head_length", 0.2 * length},
             {"head_diameter", 0.1 * length},
             {"color", colours[k]}});
      }
    }
    return {{"timestamp", stamp(utime)},
            {"frame_id", "head"},
            {"id", id},
            {"lifetime", {{"sec", 0}, {"nsec", 0}}},
            {"frame_locked", false},
            {"metadata", json::array()},
            {"arrows", arrows},
            {"cubes", orientation ? json::array({shape}) : json::array()},
            {"spheres", orientation ? json::array() : json::array({shape})},
            {"cylinders", json::array()},
            {"lines", json::array()},
            {"triangles", json::array()},
            {"texts", json::array({{{"pose", label_pose},
                                    {"billboard", true},
                                    {"font_size", 14},
                                    {"scale_invariant", true},
                                    {"color", rgba(1, 1, 1, 1)},
                                    {"text", label}}})},
            {"models", json::array()}};
  }

  static json sceneUpdate(int64_t utime, json entities) {
    return {
        {"deletions",
         json::array({{{"timestamp", stamp(utime)}, {"type", fg::kSceneDeletionAll}, {"id", ""}}})},
        {"entities", std::move(entities)}};
  }

  static bool finite3(const double (&v)[3]) {
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
  }
  static Eigen::Quaterniond quaternion(const double (&wxyz)[4]) {
    Eigen::Quaterniond q(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
    return q.norm() > 1e-9 && std::isfinite(q.norm()) ? q.normalized()
                                                      : Eigen::Quaterniond::Identity();
  }

  json trackScene(const ptzstereo::object_tracks_t& m) const {
    json entities = json::array();
    for (const auto& t : m.tracks) {
      if (!finite3(t.position_m)) continue;
      const bool target = t.id == m.target_id;
      const json colour = target                         ? rgba(1, 0.1, 0.1, 0.8)
                          : t.state == t.STATE_CONFIRMED ? rgba(0.2, 0.6, 1, 0.6)
                          : t.state == t.STATE_COASTING  ? rgba(1, 0.8, 0, 0.5)
                                                         : rgba(0.7, 0.7, 0.7, 0.4);
      const Eigen::Quaterniond q = quaternion(t.orientation_wxyz);
      entities.push_back(entity(
          "track-" + std::to_string(t.id), m.utime,
          Eigen::Vector3d(t.position_m[0], t.position_m[1], t.position_m[2]), t.radius_m,
          t.has_orientation ? &q : nullptr, colour,
          std::to_string(t.id) + " " + printable(t.class_name, 40) + (target ? " (target)" : "")));
    }
    return sceneUpdate(m.utime, entities);
  }

  json truthScene(const ptzstereo::sim_truth_t& m) const {
    json entities = json::array();
    for (const auto& o : m.objects) {
      if (!finite3(o.position_m)) continue;
      const Eigen::Quaterniond q = quaternion(o.orientation_wxyz);
      const std::string name = printable(o.name, 40);
      entities.push_back(entity("truth-" + name, m.utime,
                                Eigen::Vector3d(o.position_m[0], o.position_m[1], o.position_m[2]),
                                o.radius_m,
                                o.shape == "box" || o.shape == "tagged_box" ? &q : nullptr,
                                rgba(0.2, 1, 0.2, 0.3), name));
    }
    return sceneUpdate(m.utime, entities);
  }

  void status(const std::string& channel, const ptzstereo::process_status_t& m,
              int64_t receive_utime, std::vector<Message>* out) {
    std::string name;
    for (char c : m.process.substr(0, 64)) {
      name +=
          std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' ? c : '_';
    }
    const std::string topic_name = "/status/" + (name.empty() ? "_" : name);
    if (!topic_index.count(topic_name)) {
      if (statusTopics() >= kMaxStatusTopics) {
        countDrop(channel, "too many processes");
        return;
      }
      ptzstereo::process_status_t sample{};
      sample.channels.resize(1);
      sample.counters.resize(1);
      addTopic(topic_name, "ptzstereo.process_status_t",
               schemaOf(toJson(sample), "ptzstereo.process_status_t", {"channels", "counters"}));
    }
    out->push_back(message(topic_name, receive_utime, m.utime, toJson(m)));
  }

  size_t statusTopics() const {
    return std::count_if(topics.begin(), topics.end(),
                         [](const Topic& t) { return t.name.rfind("/status/", 0) == 0; });
  }
};

int64_t utimeToNs(int64_t utime) {
  int64_t ns;
  return __builtin_mul_overflow(std::max<int64_t>(utime, 0), 1000, &ns) ? INT64_MAX : ns;
}

Converter::Converter(StereoRig rig, ConvertOptions options)
    : impl_(std::make_unique<Impl>(std::move(rig), options)) {}
Converter::~Converter() = default;

const std::vector<Topic>& Converter::topics() const {
  return impl_->topics;
}
const std::map<std::string, int64_t>& Converter::dropped() const {
  return impl_->dropped;
}
const std::map<std::string, int64_t>& Converter::converted() const {
  return impl_->converted;
}
const std::map<std::string, int64_t>& Converter::ignored() const {
  return impl_->ignored;
}
int64_t Converter::imagesConverted() const {
  return impl_->images_converted;
}
int64_t Converter::notWanted() const {
  return impl_->not_wanted;
}
const std::map<std::string, int64_t>& Converter::decoded() const {
  return impl_->decoded;
}

std::vector<Message> Converter::convertFrame(const std::string& prefixed,
                                             const ptzstereo::stereo_frame_t& m,
                                             int64_t receive_utime) {
  Impl& d = *impl_;
  std::vector<Message> out;
  const std::string& prefix = d.options.channel_prefix;
  const bool ours = prefixed.compare(0, prefix.size(), prefix) == 0;
  const std::string channel = ours ? prefixed.substr(prefix.size()) : prefixed;
  const bool preview = channel == channels::kStereoPreview;
  if (!ours || (channel != channels::kStereoFrame && !preview)) {
    Impl::countIn(&d.ignored, printable(prefixed, 80));
    return out;
  }
  d.frame(channel, m, receive_utime, preview, &out);
  if (!out.empty()) Impl::countIn(&d.converted, printable(channel, 80));
  return out;
}

std::vector<Message> Converter::convert(const std::string& prefixed, const void* data, size_t size,
                                        int64_t receive_utime, const TopicFilter& wanted) {
  Impl& d = *impl_;
  d.wanted = &wanted;
  auto out = convertWanted(prefixed, data, size, receive_utime);
  d.wanted = nullptr;
  if (wanted) {
    out.erase(std::remove_if(out.begin(), out.end(),
                             [&wanted](const Message& m) { return !wanted(m.topic); }),
              out.end());
  }
  return out;
}

std::vector<Message> Converter::convertWanted(const std::string& prefixed, const void* data,
                                              size_t size, int64_t receive_utime) {
  namespace ch = channels;
  Impl& d = *impl_;
  std::vector<Message> out;
  const std::string& prefix = d.options.channel_prefix;
  if (prefixed.compare(0, prefix.size(), prefix) != 0) {
    Impl::countIn(&d.ignored, printable(prefixed, 80));
    return out;
  }
  const std::string channel = prefixed.substr(prefix.size());
  if (!d.wantAny(channel)) {
    ++d.not_wanted;
    return out;
  }
  // Decodes *m and converts it field for field to topic; false when it does not decode.
  const auto decodeRaw = [&](auto* m, const char* topic) {
    if (!d.decode(channel, data, size, m)) return false;
    out.push_back(d.message(topic, receive_utime, m->utime, toJson(*m)));
    return true;
  };
  if (channel == ch::kStereoFrame || channel == ch::kStereoPreview) {
    ptzstereo::stereo_frame_t m;
    if (!d.decode(channel, data, size, &m)) return out;
    d.frame(channel, m, receive_utime, channel == ch::kStereoPreview, &out);
  } else if (channel == ch::kPtzState) {
    ptzstereo::ptz_state_t m;
    if (!decodeRaw(&m, "/ptz_state")) return out;
    const double pan_tilt[2][2] = {{m.left.pan_rad, m.left.tilt_rad},
                                   {m.right.pan_rad, m.right.tilt_rad}};
    out.push_back(d.message("/tf", receive_utime, m.utime, d.transforms(m.utime, pan_tilt)));
  } else if (channel == ch::kPtzSetpoint) {
    ptzstereo::ptz_setpoint_t m;
    decodeRaw(&m, "/ptz_setpoint");
  } else if (channel == ch::kControlState) {
    ptzstereo::control_state_t m;
    decodeRaw(&m, "/control_state");
  } else if (channel == ch::kObjectDetections) {
    ptzstereo::object_detections_t m;
    if (decodeRaw(&m, "/object_detections")) d.detections(m, receive_utime, &out);
  } else if (channel == ch::kObjectPose) {
    ptzstereo::object_pose_t m;
    decodeRaw(&m, "/object_pose");
  } else if (channel == ch::kObjectTracks) {
    ptzstereo::object_tracks_t m;
    if (!decodeRaw(&m, "/object_tracks")) return out;
    out.push_back(d.message("/objects", receive_utime, m.utime, d.trackScene(m)));
  } else if (channel == ch::kSimTruth) {
    ptzstereo::sim_truth_t m;
    if (!decodeRaw(&m, "/sim_truth")) return out;
    out.push_back(d.message("/truth", receive_utime, m.utime, d.truthScene(m)));
  } else if (channel == ch::kTargetSelect) {
    ptzstereo::target_select_t m;
    decodeRaw(&m, "/target_select");
  } else if (channel == ch::kPointCloud || channel == ch::kPointCloudPreview) {
    ptzstereo::point_cloud_t m;
    if (!d.decode(channel, data, size, &m)) return out;
    const bool preview = channel == ch::kPointCloudPreview;
    if (!preview && d.cloud_schedule.enabled() && !d.cloud_schedule.take(m.utime)) return out;
    std::string text;
    if (!d.cloud(m, &text)) {
      d.countDrop(channel, "inconsistent cloud");
      return out;
    }
    out.push_back(d.textMessage(preview ? "/cloud_preview" : "/cloud", receive_utime, m.utime,
                                std::move(text)));
  } else if (channel.rfind(ch::kProcessStatusPrefix, 0) == 0) {
    ptzstereo::process_status_t m;
    if (!d.decode(channel, data, size, &m)) return out;
    d.status(channel, m, receive_utime, &out);
  } else {
    Impl::countIn(&d.ignored, printable(channel, 80));
    return out;
  }
  if (!out.empty()) Impl::countIn(&d.converted, printable(channel, 80));
  return out;
}

}  // namespace ptz::foxglove
