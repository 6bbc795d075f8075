#include <ddsnav/foxglove/schemas.hpp>

#include <map>
#include <stdexcept>

namespace ddsnav::foxglove {
namespace {

using nlohmann::json;

json number() { return {{"type", "number"}}; }
json boolean() { return {{"type", "boolean"}}; }
json string() { return {{"type", "string"}}; }
json unsignedInteger() { return {{"type", "integer"}, {"minimum", 0}}; }
json bytes() { return {{"type", "string"}, {"contentEncoding", "base64"}}; }
json arrayOf(json items) { return {{"type", "array"}, {"items", std::move(items)}}; }

// A named object type: every listed field is required, as in Foxglove's schemas.
json object(const std::string& title, std::vector<std::pair<std::string, json>> fields) {
  json properties = json::object();
  json required = json::array();
  for (auto& [name, type] : fields) {
    properties[name] = std::move(type);
    required.push_back(name);
  }
  json o = {{"type", "object"}, {"properties", std::move(properties)}, {"required", std::move(required)}};
  if (!title.empty()) o["title"] = title;
  return o;
}

// An enum: integer constants with their names.
json enumeration(const std::string& title, const std::vector<std::string>& names) {
  json cases = json::array();
  for (std::size_t i = 0; i < names.size(); ++i) cases.push_back({{"title", names[i]}, {"const", i}});
  return {{"title", title}, {"oneOf", std::move(cases)}};
}

// Foxglove writes times and durations without a required list.
json time() {
  return {{"type", "object"},
          {"title", "time"},
          {"properties",
           {{"sec", unsignedInteger()}, {"nsec", {{"type", "integer"}, {"minimum", 0}, {"maximum", 999999999}}}}}};
}
json duration() {
  return {{"type", "object"},
          {"title", "duration"},
          {"properties",
           {{"sec", {{"type", "integer"}}}, {"nsec", {{"type", "integer"}, {"minimum", 0}, {"maximum", 999999999}}}}}};
}

json vector3() { return object("foxglove.Vector3", {{"x", number()}, {"y", number()}, {"z", number()}}); }
json vector2() { return object("foxglove.Vector2", {{"x", number()}, {"y", number()}}); }
json point3() { return object("foxglove.Point3", {{"x", number()}, {"y", number()}, {"z", number()}}); }
json quaternion() {
  return object("foxglove.Quaternion", {{"x", number()}, {"y", number()}, {"z", number()}, {"w", number()}});
}
json pose() { return object("foxglove.Pose", {{"position", vector3()}, {"orientation", quaternion()}}); }
json color() { return object("foxglove.Color", {{"r", number()}, {"g", number()}, {"b", number()}, {"a", number()}}); }

json packedElementField() {
  return object("foxglove.PackedElementField",
                {{"name", string()},
                 {"offset", unsignedInteger()},
                 {"type", enumeration("foxglove.NumericType", {"UNKNOWN", "UINT8", "INT8", "UINT16", "INT16", "UINT32",
                                                               "INT32", "FLOAT32", "FLOAT64"})}});
}

json pointCloud() {
  return object("foxglove.PointCloud", {{"timestamp", time()},
                                        {"frame_id", string()},
                                        {"pose", pose()},
                                        {"point_stride", unsignedInteger()},
                                        {"fields", arrayOf(packedElementField())},
                                        {"data", bytes()}});
}

json grid() {
  return object("foxglove.Grid", {{"timestamp", time()},
                                  {"frame_id", string()},
                                  {"pose", pose()},
                                  {"column_count", unsignedInteger()},
                                  {"cell_size", vector2()},
                                  {"row_stride", unsignedInteger()},
                                  {"cell_stride", unsignedInteger()},
                                  {"fields", arrayOf(packedElementField())},
                                  {"data", bytes()}});
}

json frameTransform() {
  return object("foxglove.FrameTransform", {{"timestamp", time()},
                                            {"parent_frame_id", string()},
                                            {"child_frame_id", string()},
                                            {"translation", vector3()},
                                            {"rotation", quaternion()}});
}

json sizedPrimitive(const std::string& title) {
  return object(title, {{"pose", pose()}, {"size", vector3()}, {"color", color()}});
}

json sceneEntity() {
  json arrow = object("foxglove.ArrowPrimitive", {{"pose", pose()},
                                                  {"shaft_length", number()},
                                                  {"shaft_diameter", number()},
                                                  {"head_length", number()},
                                                  {"head_diameter", number()},
                                                  {"color", color()}});
  json cylinder = object("foxglove.CylinderPrimitive", {{"pose", pose()},
                                                        {"size", vector3()},
                                                        {"bottom_scale", number()},
                                                        {"top_scale", number()},
                                                        {"color", color()}});
  json line = object("foxglove.LinePrimitive",
                     {{"type", enumeration("foxglove.LineType", {"LINE_STRIP", "LINE_LOOP", "LINE_LIST"})},
                      {"pose", pose()},
                      {"thickness", number()},
                      {"scale_invariant", boolean()},
                      {"points", arrayOf(point3())},
                      {"color", color()},
                      {"colors", arrayOf(color())},
                      {"indices", arrayOf(unsignedInteger())}});
  json triangles = object("foxglove.TriangleListPrimitive", {{"pose", pose()},
                                                             {"points", arrayOf(point3())},
                                                             {"color", color()},
                                                             {"colors", arrayOf(color())},
                                                             {"indices", arrayOf(unsignedInteger())}});
  json text = object("foxglove.TextPrimitive", {{"pose", pose()},
                                                {"billboard", boolean()},
                                                {"font_size", number()},
                                                {"scale_invariant", boolean()},
                                                {"color", color()},
                                                {"text", string()}});
  json model = object("foxglove.ModelPrimitive", {{"pose", pose()},
                                                  {"scale", vector3()},
                                                  {"color", color()},
                                                  {"override_color", boolean()},
                                                  {"url", string()},
                                                  {"media_type", string()},
                                                  {"data", bytes()}});
  json key_value = object("foxglove.KeyValuePair", {{"key", string()}, {"value", string()}});
  return object("foxglove.SceneEntity", {{"timestamp", time()},
                                         {"frame_id", string()},
                                         {"id", string()},
                                         {"lifetime", duration()},
                                         {"frame_locked", boolean()},
                                         {"metadata", arrayOf(key_value)},
                                         {"arrows", arrayOf(arrow)},
                                         {"cubes", arrayOf(sizedPrimitive("foxglove.CubePrimitive"))},
                                         {"spheres", arrayOf(sizedPrimitive("foxglove.SpherePrimitive"))},
                                         {"cylinders", arrayOf(cylinder)},
                                         {"lines", arrayOf(line)},
                                         {"triangles", arrayOf(triangles)},
                                         {"texts", arrayOf(text)},
                                         {"models", arrayOf(model)}});
}

json sceneUpdate() {
  json deletion = object("foxglove.SceneEntityDeletion",
                         {{"timestamp", time()},
                          {"type", enumeration("foxglove.SceneEntityDeletionType", {"MATCHING_ID", "ALL"})},
                          {"id", string()}});
  return object("foxglove.SceneUpdate", {{"deletions", arrayOf(deletion)}, {"entities", arrayOf(sceneEntity())}});
}

const std::map<std::string, json, std::less<>>& table() {
  static const std::map<std::string, json, std::less<>> schemas = {
      {"foxglove.PointCloud", pointCloud()},
      {"foxglove.SceneUpdate", sceneUpdate()},
      {"foxglove.Grid", grid()},
      {"foxglove.FrameTransform", frameTransform()},
  };
  return schemas;
}

}  // namespace

const std::vector<std::string>& schemaNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& [name, schema] : table()) n.push_back(name);
    return n;
  }();
  return names;
}

const nlohmann::json& jsonSchema(std::string_view schema_name) {
  const auto it = table().find(schema_name);
  if (it == table().end()) throw std::out_of_range("no Foxglove schema named '" + std::string(schema_name) + "'");
  return it->second;
}

}  // namespace ddsnav::foxglove
