#include "tools/foxglove/foxglove_schemas.hpp"

#include <map>
#include <stdexcept>

namespace ptz::foxglove {
namespace {

using nlohmann::json;

json object(json properties) {
  json required = json::array();
  for (auto it = properties.begin(); it != properties.end(); ++it) required.push_back(it.key());
  return {{"type", "object"}, {"properties", std::move(properties)}, {"required", required}};
}
json arrayOf(json items) {
  return {{"type", "array"}, {"items", std::move(items)}};
}
json numberArray(int n) {
  json a = arrayOf({{"type", "number"}});
  a["minItems"] = n;
  a["maxItems"] = n;
  return a;
}
const json kNumber = {{"type", "number"}};
const json kInteger = {{"type", "integer"}};
const json kString = {{"type", "string"}};
const json kBoolean = {{"type", "boolean"}};
const json kBase64 = {{"type", "string"}, {"contentEncoding", "base64"}};
json time() {
  return object({{"sec", {{"type", "integer"}, {"minimum", 0}}},
                 {"nsec", {{"type", "integer"}, {"minimum", 0}, {"maximum", 999999999}}}});
}
json duration() {
  return object(
      {{"sec", kInteger}, {"nsec", {{"type", "integer"}, {"minimum", 0}, {"maximum", 999999999}}}});
}
json vector3() {
  return object({{"x", kNumber}, {"y", kNumber}, {"z", kNumber}});
}
json quaternion() {
  return object({{"x", kNumber}, {"y", kNumber}, {"z", kNumber}, {"w", kNumber}});
}
json pose() {
  return object({{"position", vector3()}, {"orientation", quaternion()}});
}
json color() {
  return object({{"r", kNumber}, {"g", kNumber}, {"b", kNumber}, {"a", kNumber}});
}
json point2() {
  return object({{"x", kNumber}, {"y", kNumber}});
}
json enumOf(int last) {
  json e = kInteger;
  e["minimum"] = 0;
  e["maximum"] = last;
  return e;
}
json titled(json schema, const std::string& name) {
  schema["title"] = name;
  schema["$schema"] = "https://json-schema.org/draft/2020-12/schema";
  return schema;
}

std::map<std::string, json> makeSchemas() {
  std::map<std::string, json> s;
  s["foxglove.CompressedImage"] = object(
      {{"timestamp", time()}, {"frame_id", kString}, {"data", kBase64}, {"format", kString}});
  s["foxglove.CameraCalibration"] = object({{"timestamp", time()},
                                            {"frame_id", kString},
                                            {"width", kInteger},
                                            {"height", kInteger},
                                            {"distortion_model", kString},
                                            {"D", arrayOf(kNumber)},
                                            {"K", numberArray(9)},
                                            {"R", numberArray(9)},
                                            {"P", numberArray(12)}});
  s["foxglove.ImageAnnotations"] =
      object({{"circles", arrayOf(object({{"timestamp", time()},
                                          {"position", point2()},
                                          {"diameter", kNumber},
                                          {"thickness", kNumber},
                                          {"fill_color", color()},
                                          {"outline_color", color()}}))},
              {"points", arrayOf(object({{"timestamp", time()},
                                         {"type", enumOf(4)},
                                         {"points", arrayOf(point2())},
                                         {"outline_color", color()},
                                         {"outline_colors", arrayOf(color())},
                                         {"fill_color", color()},
                                         {"thickness", kNumber}}))},
              {"texts", arrayOf(object({{"timestamp", time()},
                                        {"position", point2()},
                                        {"text", kString},
                                        {"font_size", kNumber},
                                        {"text_color", color()},
                                        {"background_color", color()}}))}});
  s["foxglove.FrameTransforms"] =
      object({{"transforms", arrayOf(object({{"timestamp", time()},
                                             {"parent_frame_id", kString},
                                             {"child_frame_id", kString},
                                             {"translation", vector3()},
                                             {"rotation", quaternion()}}))}});
  s["foxglove.PointCloud"] = object(
      {{"timestamp", time()},
       {"frame_id", kString},
       {"pose", pose()},
       {"point_stride", kInteger},
       {"fields", arrayOf(object({{"name", kString}, {"offset", kInteger}, {"type", enumOf(8)}}))},
       {"data", kBase64}});
  const json sphere = object({{"pose", pose()}, {"size", vector3()}, {"color", color()}});
  const json text = object({{"pose", pose()},
                            {"billboard", kBoolean},
                            {"font_size", kNumber},
                            {"scale_invariant", kBoolean},
                            {"color", color()},
                            {"text", kString}});
  // Primitives the converter never draws are empty arrays; their items stay unconstrained here.
  const json none = {{"type", "array"}, {"maxItems", 0}};
  s["foxglove.SceneUpdate"] = object(
      {{"deletions",
        arrayOf(object({{"timestamp", time()}, {"type", enumOf(1)}, {"id", kString}}))},
       {"entities",
        arrayOf(object({{"timestamp", time()},
                        {"frame_id", kString},
                        {"id", kString},
                        {"lifetime", duration()},
                        {"frame_locked", kBoolean},
                        {"metadata", arrayOf(object({{"key", kString}, {"value", kString}}))},
                        {"arrows", none},
                        {"cubes", arrayOf(sphere)},
                        {"spheres", arrayOf(sphere)},
                        {"cylinders", none},
                        {"lines", none},
                        {"triangles", none},
                        {"texts", arrayOf(text)},
                        {"models", none}}))}});
  s["foxglove.PosesInFrame"] =
      object({{"timestamp", time()}, {"frame_id", kString}, {"poses", arrayOf(pose())}});
  for (auto& [name, schema] : s) schema = titled(schema, name);
  return s;
}

}  // namespace

const json& foxgloveSchema(const std::string& name) {
  static const std::map<std::string, json> schemas = makeSchemas();
  const auto it = schemas.find(name);
  if (it == schemas.end()) throw std::invalid_argument("no Foxglove schema written for " + name);
  return it->second;
}

}  // namespace ptz::foxglove
