#include "tools/foxglove/lcm_json.hpp"

#include <cmath>

namespace ptz::foxglove {
namespace {

using nlohmann::json;

json number(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

template <size_t N>
json numbers(const double (&v)[N]) {
  json a = json::array();
  for (double x : v) a.push_back(number(x));
  return a;
}

json head(const ptzstereo::ptz_head_state_t& h) {
  return {{"pan_rad", number(h.pan_rad)},
          {"tilt_rad", number(h.tilt_rad)},
          {"zoom", number(h.zoom)},
          {"pan_rate_rad_s", number(h.pan_rate_rad_s)},
          {"tilt_rate_rad_s", number(h.tilt_rate_rad_s)},
          {"zoom_rate_per_s", number(h.zoom_rate_per_s)},
          {"at_limit", h.at_limit}};
}

json head(const ptzstereo::ptz_head_setpoint_t& h) {
  return {
      {"pan_rad", number(h.pan_rad)}, {"tilt_rad", number(h.tilt_rad)}, {"zoom", number(h.zoom)}};
}

json detection(const ptzstereo::detection_2d_t& d) {
  return {{"class_name", d.class_name},
          {"centroid_x_px", number(d.centroid_x_px)},
          {"centroid_y_px", number(d.centroid_y_px)},
          {"area_px2", number(d.area_px2)},
          {"bbox_x_px", d.bbox_x_px},
          {"bbox_y_px", d.bbox_y_px},
          {"bbox_width_px", d.bbox_width_px},
          {"bbox_height_px", d.bbox_height_px},
          {"shape_distance", number(d.shape_distance)},
          {"match_index", d.match_index}};
}

json camera(const ptzstereo::camera_model_t& c) {
  return {{"width", c.width},
          {"height", c.height},
          {"fx_px", number(c.fx_px)},
          {"fy_px", number(c.fy_px)},
          {"cx_px", number(c.cx_px)},
          {"cy_px", number(c.cy_px)},
          {"distortion", numbers(c.distortion)},
          {"rotation_head_camera", numbers(c.rotation_head_camera)},
          {"position_head_m", numbers(c.position_head_m)}};
}

json stamps(int64_t utime, int64_t publish_utime, int64_t frame_seq) {
  return {{"utime", utime}, {"publish_utime", publish_utime}, {"frame_seq", frame_seq}};
}

}  // namespace

json toJson(const ptzstereo::ptz_state_t& m) {
  return {{"utime", m.utime},
          {"publish_utime", m.publish_utime},
          {"left", head(m.left)},
          {"right", head(m.right)},
          {"setpoint_utime", m.setpoint_utime}};
}

json toJson(const ptzstereo::ptz_setpoint_t& m) {
  json j = stamps(m.utime, m.publish_utime, m.frame_seq);
  j["left"] = head(m.left);
  j["right"] = head(m.right);
  return j;
}

json toJson(const ptzstereo::control_state_t& m) {
  static const char* const kNames[] = {"tracking", "coasting", "searching", "holding", "homing"};
  json j = stamps(m.utime, m.publish_utime, m.frame_seq);
  j["state"] = m.state;
  j["state_name"] = m.state >= 0 && m.state <= 4 ? kNames[m.state] : "unknown";
  j["target_id"] = m.target_id;
  j["since_target_s"] = number(m.since_target_s);
  j["search_waypoint"] = m.search_waypoint;
  j["search_waypoints"] = m.search_waypoints;
  j["reason"] = m.reason;
  return j;
}

json toJson(const ptzstereo::object_detections_t& m) {
  json j = stamps(m.utime, m.publish_utime, m.frame_seq);
  j["left"] = json::array();
  j["right"] = json::array();
  for (const auto& d : m.left) j["left"].push_back(detection(d));
  for (const auto& d : m.right) j["right"].push_back(detection(d));
  return j;
}

json toJson(const ptzstereo::object_pose_t& m) {
  json j = stamps(m.utime, m.publish_utime, m.frame_seq);
  j["left_ptz"] = head(m.left_ptz);
  j["right_ptz"] = head(m.right_ptz);
  j["target_index"] = m.target_index;
  j["objects"] = json::array();
  for (const auto& o : m.objects) {
    j["objects"].push_back(
        {{"class_name", o.class_name},
         {"position_m", numbers(o.position_m)},
         {"covariance_m2", numbers(o.covariance_m2)},
         {"radius_m", number(o.radius_m)},
         {"left_index", o.left_index},
         {"right_index", o.right_index},
         {"has_orientation", o.has_orientation},
         {"orientation_wxyz", numbers(o.orientation_wxyz)},
         {"orientation_covariance_rad2", numbers(o.orientation_covariance_rad2)}});
  }
  return j;
}

json toJson(const ptzstereo::object_tracks_t& m) {
  static const char* const kStates[] = {"tentative", "confirmed", "coasting"};
  json j = stamps(m.utime, m.publish_utime, m.frame_seq);
  j["left_ptz"] = head(m.left_ptz);
  j["right_ptz"] = head(m.right_ptz);
  j["target_id"] = m.target_id;
  j["target_reason"] = m.target_reason;
  j["tracks"] = json::array();
  for (const auto& t : m.tracks) {
    j["tracks"].push_back(
        {{"id", t.id},
         {"class_name", t.class_name},
         {"state", t.state},
         {"state_name", t.state >= 0 && t.state <= 2 ? kStates[t.state] : "unknown"},
         {"position_m", numbers(t.position_m)},
         {"position_covariance_m2", numbers(t.position_covariance_m2)},
         {"velocity_m_s", numbers(t.velocity_m_s)},
         {"velocity_covariance_m2_s2", numbers(t.velocity_covariance_m2_s2)},
         {"acceleration_m_s2", numbers(t.acceleration_m_s2)},
         {"radius_m", number(t.radius_m)},
         {"age_s", number(t.age_s)},
         {"since_update_s", number(t.since_update_s)},
         {"object_index", t.object_index},
         {"untrusted_updates", t.untrusted_updates},
         {"has_orientation", t.has_orientation},
         {"orientation_wxyz", numbers(t.orientation_wxyz)},
         {"orientation_covariance_rad2", numbers(t.orientation_covariance_rad2)}});
  }
  return j;
}

json toJson(const ptzstereo::sim_truth_t& m) {
  json j = stamps(m.utime, m.publish_utime, m.frame_seq);
  j["left_head"] = head(m.left_head);
  j["right_head"] = head(m.right_head);
  j["left_camera"] = camera(m.left_camera);
  j["right_camera"] = camera(m.right_camera);
  j["objects"] = json::array();
  for (const auto& o : m.objects) {
    j["objects"].push_back({{"name", o.name},
                            {"class_name", o.class_name},
                            {"shape", o.shape},
                            {"position_m", numbers(o.position_m)},
                            {"velocity_m_s", numbers(o.velocity_m_s)},
                            {"radius_m", number(o.radius_m)},
                            {"orientation_wxyz", numbers(o.orientation_wxyz)},
                            {"visible_fraction", numbers(o.visible_fraction)}});
  }
  return j;
}

json toJson(const ptzstereo::target_select_t& m) {
  return {
      {"utime", m.utime},           {"publish_utime", m.publish_utime}, {"mode", m.mode},
      {"class_name", m.class_name}, {"track_id", m.track_id},           {"camera", m.camera},
      {"x_px", number(m.x_px)},     {"y_px", number(m.y_px)},           {"frame_seq", m.frame_seq}};
}

json toJson(const ptzstereo::process_status_t& m) {
  static const char* const kStates[] = {"OK", "WARN", "ERROR"};
  json j = {{"utime", m.utime},
            {"process", m.process},
            {"hostname", m.hostname},
            {"pid", m.pid},
            {"uptime_s", number(m.uptime_s)},
            {"state", m.state},
            {"state_name", m.state >= 0 && m.state <= 2 ? kStates[m.state] : "unknown"},
            {"message", m.message},
            {"channels", json::object()},
            {"counters", json::object()}};
  for (const auto& c : m.channels) {
    // The same channel may be both in and out (rare): the key says which.
    const std::string key = c.channel + (c.direction == c.DIRECTION_OUT ? ".out" : ".in");
    j["channels"][key] = {{"direction", c.direction == c.DIRECTION_OUT ? "out" : "in"},
                          {"rate_hz", number(c.rate_hz)},
                          {"messages", c.messages},
                          {"dropped", c.dropped},
                          {"latency_ms_p50", number(c.latency_ms_p50)},
                          {"latency_ms_p99", number(c.latency_ms_p99)}};
  }
  for (const auto& c : m.counters) j["counters"][c.name] = c.value;
  return j;
}

json schemaOf(const json& sample, const std::string& title, const std::vector<std::string>& maps) {
  std::function<json(const json&, const std::string&)> of = [&](const json& v,
                                                                const std::string& path) -> json {
    if (v.is_object()) {
      const bool is_map = std::find(maps.begin(), maps.end(), path) != maps.end();
      if (is_map) {
        json values = v.empty() ? json::object() : of(v.begin().value(), path + ".*");
        return {{"type", "object"}, {"additionalProperties", values}};
      }
      json props = json::object();
      json required = json::array();
      for (auto it = v.begin(); it != v.end(); ++it) {
        props[it.key()] = of(it.value(), path.empty() ? it.key() : path + "." + it.key());
        required.push_back(it.key());
      }
      return {{"type", "object"}, {"properties", props}, {"required", required}};
    }
    if (v.is_array()) {
      json s = {{"type", "array"}};
      if (!v.empty()) s["items"] = of(v.front(), path + "[]");
      return s;
    }
    if (v.is_boolean()) return {{"type", "boolean"}};
    if (v.is_string()) return {{"type", "string"}};
    if (v.is_number_integer()) return {{"type", "integer"}};
    return {{"type", json::array({"number", "null"})}};
  };
  json s = of(sample, "");
  s["title"] = title;
  s["$schema"] = "https://json-schema.org/draft/2020-12/schema";
  return s;
}

std::string dumpJson(const json& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

}  // namespace ptz::foxglove
