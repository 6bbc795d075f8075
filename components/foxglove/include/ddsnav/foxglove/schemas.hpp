// Foxglove's own message schemas (https://docs.foxglove.dev/docs/visualization/message-schemas), as the
// JSON Schemas Foxglove reads with the `jsonschema` schema encoding and `json` message encoding. Only the
// types ddsnav draws are here. Field names, nesting, types and required lists follow Foxglove's published
// definitions exactly (checked against the @foxglove/schemas package by tests/bridge); the descriptions
// are left out.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace ddsnav::foxglove {

inline constexpr std::string_view kSchemaEncoding = "jsonschema";
inline constexpr std::string_view kMessageEncoding = "json";

// The schema names ddsnav emits: "foxglove.PointCloud", "foxglove.SceneUpdate", "foxglove.Grid",
// "foxglove.FrameTransform".
const std::vector<std::string>& schemaNames();

// The JSON Schema of one of schemaNames(); throws std::out_of_range naming the unknown schema.
const nlohmann::json& jsonSchema(std::string_view schema_name);

}  // namespace ddsnav::foxglove
