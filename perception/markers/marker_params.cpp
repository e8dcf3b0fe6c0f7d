#include "perception/markers/marker_params.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <set>

#include "common/config.hpp"
#include "common/markers.hpp"

namespace ptz::perception {

std::string MarkerClass::objectName(int id) const {
  if (isBundle()) return bundleTag(id) ? name : "";
  if (any_id || std::find(ids.begin(), ids.end(), id) != ids.end()) {
    return name + "#" + std::to_string(id);
  }
  return "";
}

const MarkerTag* MarkerClass::bundleTag(int id) const {
  for (const auto& t : bundle) {
    if (t.id == id) return &t;
  }
  return nullptr;
}

std::vector<Eigen::Vector3d> MarkerClass::corners(int id) const {
  const double h = size_m / 2;
  const Eigen::Vector3d in_tag[4] = {{-h, -h, 0}, {h, -h, 0}, {h, h, 0}, {-h, h, 0}};
  std::vector<Eigen::Vector3d> out;
  const MarkerTag* t = bundleTag(id);
  for (const auto& c : in_tag) {
    out.push_back(t ? Eigen::Vector3d(t->centre_m + t->rotation_object_tag * c) : c);
  }
  return out;
}

double MarkerClass::radiusM() const {
  double r = size_m / std::sqrt(2.0);
  for (const auto& t : bundle) r = std::max(r, t.centre_m.norm() + size_m / std::sqrt(2.0));
  return r;
}

std::vector<std::string> markerObjectNames(const std::vector<MarkerClass>& classes) {
  std::vector<std::string> names;
  for (const auto& c : classes) {
    if (c.isBundle()) {
      names.push_back(c.name);
      continue;
    }
    const int count = markerFamilyCount(c.family);
    for (int id = 0; id < count; ++id) {
      if (!c.objectName(id).empty()) names.push_back(c.objectName(id));
    }
  }
  return names;
}

std::vector<MarkerClass> markerClassesFromConfig(const cv::FileNode& markers,
                                                 const std::string& where) {
  std::vector<MarkerClass> classes;
  if (markers.empty() || markers.isNone()) return classes;
  if (!markers.isSeq()) throw ConfigError(where + ", markers: must be a list");
  int i = 0;
  std::set<std::string> names;
  for (const auto& n : markers) {
    const std::string w = where + ", markers[" + std::to_string(i++) + "]";
    checkFields(n, {"name", "detector", "family", "size_m", "ids", "tags"}, w);
    MarkerClass c;
    c.name = readString(n, "name", w);
    if (c.name.empty() || c.name.find('#') != std::string::npos) {
      throw ConfigError(fieldPath(w, "name") + ": must be non-empty and without '#', got '" +
                        c.name + "'");
    }
    if (!names.insert(c.name).second) {
      throw ConfigError(fieldPath(w, "name") + ": a second marker class named '" + c.name + "'");
    }
    if (!n["detector"].empty()) c.detector = readString(n, "detector", w);
    if (c.detector != "apriltag" && c.detector != "aruco") {
      throw ConfigError(fieldPath(w, "detector") + ": must be apriltag or aruco, got '" +
                        c.detector + "'");
    }
    if (!n["family"].empty()) c.family = readString(n, "family", w);
    const int count = markerFamilyCount(c.family);
    if (count == 0) {
      std::string known;
      for (const auto& f : markerFamilies()) known += (known.empty() ? "" : ", ") + f;
      throw ConfigError(fieldPath(w, "family") + ": unknown family '" + c.family +
                        "' (known: " + known + ")");
    }
    if (c.detector == "apriltag" && c.family != "apriltag_36h11" && c.family != "apriltag_25h9" &&
        c.family != "apriltag_16h5") {
      throw ConfigError(fieldPath(w, "family") +
                        ": detector apriltag reads apriltag_36h11, apriltag_25h9 or "
                        "apriltag_16h5, got '" +
                        c.family + "'");
    }
    c.size_m = readDouble(n, "size_m", w, Range::between(0.001, 10));
    const Range id_range = Range::between(0, count - 1);
    if (!n["tags"].empty()) {
      if (!n["ids"].empty()) throw ConfigError(w + ": either ids or tags, not both");
      const cv::FileNode tags = n["tags"];
      if (!tags.isSeq() || tags.size() == 0) {
        throw ConfigError(fieldPath(w, "tags") + ": must be a non-empty list");
      }
      int k = 0;
      for (const auto& t : tags) {
        const std::string tw = w + ".tags[" + std::to_string(k++) + "]";
        checkFields(t, {"id", "centre_m", "yaw_deg", "pitch_deg"}, tw);
        MarkerTag tag;
        tag.id = readInt(t, "id", tw, id_range);
        if (c.bundleTag(tag.id)) {
          throw ConfigError(fieldPath(tw, "id") + ": tag " + std::to_string(tag.id) + " twice");
        }
        const std::vector<double> p = readNumbers(t, "centre_m", 3, tw, Range::between(-10, 10));
        tag.centre_m = {p[0], p[1], p[2]};
        tag.rotation_object_tag =
            tagRotation(readDouble(t, "yaw_deg", tw, 0, Range::between(-360, 360)),
                        readDouble(t, "pitch_deg", tw, 0, Range::between(-360, 360)));
        c.bundle.push_back(tag);
      }
    } else if (n["ids"].isString()) {
      const std::string any = readString(n, "ids", w);
      if (any != "any") {
        throw ConfigError(fieldPath(w, "ids") + ": a list of ids or \"any\", got '" + any + "'");
      }
      c.any_id = true;
    } else {
      for (double id : readNumberList(n, "ids", w, id_range)) {
        if (id != std::floor(id)) {
          throw ConfigError(fieldPath(w, "ids") + ": ids are integers, got " + std::to_string(id));
        }
        c.ids.push_back(static_cast<int>(id));
      }
    }
    for (const auto& other : classes) {
      if (other.family != c.family) continue;
      for (int id = 0; id < count; ++id) {
        if (!c.objectName(id).empty() && !other.objectName(id).empty()) {
          throw ConfigError(w + ": tag " + std::to_string(id) + " of " + c.family +
                            " is also class '" + other.name + "''s");
        }
      }
    }
    classes.push_back(c);
  }
  return classes;
}

}  // namespace ptz::perception
