// JSON Schemas of the Foxglove message types the converter writes (foxglove.CompressedImage and
// the others of https://docs.foxglove.dev/docs/visualization/message-schemas), as much of each as
// the converter fills: every property it writes, typed as Foxglove's own schema types it. The
// tests check each written message against Foxglove's published schemas (@foxglove/schemas).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace ptz::foxglove {

// The schema of a foxglove.* type by name ("foxglove.CompressedImage"); throws
// std::invalid_argument for a type the converter does not write.
const nlohmann::json& foxgloveSchema(const std::string& name);

// Foxglove's enums, as its schemas number them.
namespace fg {
constexpr int kPointsLineLoop = 2;    // PointsAnnotation.type
constexpr int kSceneDeletionAll = 1;  // SceneEntityDeletion.type
enum PackedType {
  kUint8 = 1,
  kInt8 = 2,
  kUint16 = 3,
  kInt16 = 4,
  kUint32 = 5,
  kInt32 = 6,
  kFloat32 = 7,
  kFloat64 = 8
};  // PackedElementField.type
}  // namespace fg

}  // namespace ptz::foxglove
