// The Foxglove conversions without DDS: every derived message conforms to the JSON Schema it is
// published with (checked by a small validator of the keywords Foxglove's schemas use), and carries the
// geometry of its source. tests/bridge checks these schemas against Foxglove's published ones.
#include <ddsnav/foxglove/derived.hpp>
#include <ddsnav/foxglove/schemas.hpp>
#include <ddsnav/foxglove/svg.hpp>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

using namespace ddsnav;
using nlohmann::json;

namespace {

// Errors of `value` against `schema` (type, properties, required, items, oneOf/const, minimum/maximum).
void validate(const json& schema, const json& value, const std::string& at, std::vector<std::string>& errors) {
  if (schema.contains("oneOf")) {
    for (const auto& option : schema["oneOf"])
      if (option.contains("const") && option["const"] == value) return;
    errors.push_back(at + ": " + value.dump() + " is none of the enum's values");
    return;
  }
  const std::string type = schema.value("type", "");
  if (type == "object") {
    if (!value.is_object()) return errors.push_back(at + ": expected an object");
    for (const auto& name : schema.value("required", json::array()))
      if (!value.contains(name.get<std::string>())) errors.push_back(at + ": missing " + name.get<std::string>());
    for (const auto& [name, sub] : value.items()) {
      if (!schema["properties"].contains(name)) errors.push_back(at + ": unknown field " + name);
      else validate(schema["properties"][name], sub, at + "." + name, errors);
    }
  } else if (type == "array") {
    if (!value.is_array()) return errors.push_back(at + ": expected an array");
    for (std::size_t i = 0; i < value.size(); ++i) validate(schema["items"], value[i], at + "[" + std::to_string(i) + "]", errors);
  } else if (type == "number" || type == "integer") {
    if (!value.is_number() || (type == "integer" && !value.is_number_integer())) return errors.push_back(at + ": expected " + type);
    if (schema.contains("minimum") && value.get<double>() < schema["minimum"].get<double>()) errors.push_back(at + ": below minimum");
    if (schema.contains("maximum") && value.get<double>() > schema["maximum"].get<double>()) errors.push_back(at + ": above maximum");
  } else if (type == "string") {
    if (!value.is_string()) errors.push_back(at + ": expected a string");
  } else if (type == "boolean") {
    if (!value.is_boolean()) errors.push_back(at + ": expected a boolean");
  } else {
    errors.push_back(at + ": schema without a type");
  }
}

void expectConforms(const std::string& schema_name, const json& message) {
  std::vector<std::string> errors;
  validate(foxglove::jsonSchema(schema_name), message, schema_name, errors);
  EXPECT_TRUE(errors.empty()) << errors.size() << " errors, first: " << (errors.empty() ? "" : errors.front());
}

std::vector<std::uint8_t> unbase64(const std::string& text) {
  auto digit = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    return c == '+' ? 62 : c == '/' ? 63 : -1;
  };
  std::vector<std::uint8_t> out;
  std::uint32_t bits = 0;
  int n = 0;
  for (char c : text) {
    if (c == '=') break;
    bits = (bits << 6) | digit(c);
    if ((n += 6) >= 8) out.push_back((bits >> (n -= 8)) & 0xff);
  }
  return out;
}


msg::Vec3 v3(double x, double y, double z) {
  msg::Vec3 v;
  v.x(x), v.y(y), v.z(z);
  return v;
}

msg::ObstacleArray ellipses() {
  msg::ObstacleArray a;
  a.header().stamp_ns(1'500'000'123);
  a.header().frame_id("map");
  a.planar(true);
  msg::ObstacleEllipsoid o;
  o.id(7);
  o.centre(v3(4, 5, 0));
  o.semi_axes(v3(2, 1, 0));
  msg::Quaternion q;
  q.z(std::sin(0.25)), q.w(std::cos(0.25));  // yaw 0.5 rad
  o.orientation(q);
  o.probability_bound(0.99);
  o.point_count(42);
  a.obstacles().push_back(o);
  return a;
}

msg::VehicleState vehicleAt(double x, double y, double heading, std::int64_t stamp) {
  msg::VehicleState s;
  s.header().stamp_ns(stamp);
  s.header().frame_id("map");
  s.position(v3(x, y, 0));
  s.heading(heading);
  return s;
}

// A tree with occupied cells at the given points (and free space along the ray from the origin to them).
msg::OccupancyMap mapWith(const std::vector<octomap::point3d>& occupied) {
  octomap::OcTree tree(0.5);
  for (const auto& p : occupied) tree.updateNode(p, true);
  tree.updateNode(octomap::point3d(0.25f, 0.25f, 0.25f), false);
  std::ostringstream out;
  tree.writeBinary(out);
  const std::string bytes = out.str();
  msg::OccupancyMap map;
  map.header().stamp_ns(10);
  map.header().frame_id("map");
  map.resolution(0.5);
  map.bounds_min(v3(0, 0, 0));
  map.bounds_max(v3(4, 4, 1));
  map.octree().assign(bytes.begin(), bytes.end());
  return map;
}

}  // namespace

TEST(FoxgloveSchemas, EveryNameHasItsTitledObjectSchema) {
  ASSERT_EQ(foxglove::schemaNames().size(), 4u);
  for (const auto& name : foxglove::schemaNames()) {
    const json& s = foxglove::jsonSchema(name);
    EXPECT_EQ(s["title"], name);
    EXPECT_EQ(s["type"], "object");
    EXPECT_EQ(s["required"].size(), s["properties"].size()) << name;
  }
  EXPECT_THROW(foxglove::jsonSchema("foxglove.Nope"), std::out_of_range);
}

TEST(FoxgloveBase64, Rfc4648Vectors) {
  auto b64 = [](const std::string& s) { return foxglove::base64(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()); };
  EXPECT_EQ(b64(""), "");
  EXPECT_EQ(b64("f"), "Zg==");
  EXPECT_EQ(b64("fo"), "Zm8=");
  EXPECT_EQ(b64("foo"), "Zm9v");
  EXPECT_EQ(b64("foob"), "Zm9vYg==");
  EXPECT_EQ(b64("foobar"), "Zm9vYmFy");
}

TEST(FoxglovePointCloud, PacksXyzAndIntensityAsFloat32) {
  msg::PointCloud c;
  c.header().stamp_ns(3'000'000'007);
  c.header().frame_id("map");
  c.xyz({1.f, 2.f, 3.f, -4.f, 5.5f, 6.f});
  c.intensity({0.25f, 0.75f});
  const json m = foxglove::pointCloud(c);
  expectConforms("foxglove.PointCloud", m);
  EXPECT_EQ(m["timestamp"]["sec"], 3);
  EXPECT_EQ(m["timestamp"]["nsec"], 7);
  EXPECT_EQ(m["point_stride"], 16);
  ASSERT_EQ(m["fields"].size(), 4u);
  EXPECT_EQ(m["fields"][3]["name"], "intensity");
  const auto data = unbase64(m["data"]);
  ASSERT_EQ(data.size(), 32u);
  float p[8];
  std::memcpy(p, data.data(), 32);
  EXPECT_EQ(p[4], -4.f);
  EXPECT_EQ(p[5], 5.5f);
  EXPECT_EQ(p[7], 0.75f);

  c.intensity({});
  EXPECT_EQ(foxglove::pointCloud(c)["point_stride"], 12);
  c.xyz({1.f, 2.f});
  EXPECT_THROW(foxglove::pointCloud(c), foxglove::ConversionError);
  c.xyz({1.f, 2.f, 3.f});
  c.intensity({1.f, 2.f});
  EXPECT_THROW(foxglove::pointCloud(c), foxglove::ConversionError);
}

TEST(FoxgloveObstacles, EllipseIsAFlatScaledTurnedSphereWithItsProbability) {
  const json m = foxglove::obstacleScene(ellipses());
  expectConforms("foxglove.SceneUpdate", m);
  ASSERT_EQ(m["deletions"].size(), 1u);
  EXPECT_EQ(m["deletions"][0]["type"], 1);  // ALL: the array replaces the previous one
  ASSERT_EQ(m["entities"].size(), 1u);
  const json& e = m["entities"][0];
  EXPECT_EQ(e["id"], "obstacle/7");
  const json& sphere = e["spheres"][0];
  EXPECT_DOUBLE_EQ(sphere["size"]["x"], 4.0);
  EXPECT_DOUBLE_EQ(sphere["size"]["y"], 2.0);
  EXPECT_DOUBLE_EQ(sphere["size"]["z"], 0.05);
  EXPECT_NEAR(sphere["pose"]["orientation"]["z"].get<double>(), std::sin(0.25), 1e-12);
  EXPECT_DOUBLE_EQ(sphere["pose"]["position"]["y"], 5.0);
  EXPECT_EQ(e["texts"][0]["text"], "p 0.99");
  EXPECT_EQ(e["metadata"][0]["key"], "probability_bound");
  EXPECT_EQ(e["metadata"][0]["value"], "0.9900");
  EXPECT_EQ(e["metadata"][1]["value"], "42");
}

TEST(FoxgloveObstacles, EllipsoidKeepsItsHeightAndQuaternion) {
  auto a = ellipses();
  a.planar(false);
  a.obstacles()[0].semi_axes(v3(2, 1, 0.5));
  msg::Quaternion q;
  q.x(0), q.y(0), q.z(0), q.w(2);  // not unit: normalised
  a.obstacles()[0].orientation(q);
  const json m = foxglove::obstacleScene(a);
  EXPECT_DOUBLE_EQ(m["entities"][0]["spheres"][0]["size"]["z"], 1.0);
  EXPECT_DOUBLE_EQ(m["entities"][0]["spheres"][0]["pose"]["orientation"]["w"], 1.0);
}

TEST(FoxgloveObstacles, BadValuesNameTheField) {
  auto a = ellipses();
  a.obstacles()[0].centre(v3(std::numeric_limits<double>::quiet_NaN(), 0, 0));
  try {
    foxglove::obstacleScene(a);
    FAIL() << "NaN accepted";
  } catch (const foxglove::ConversionError& e) {
    EXPECT_NE(std::string(e.what()).find("obstacles[0].centre.x"), std::string::npos) << e.what();
  }
  a = ellipses();
  a.obstacles()[0].semi_axes(v3(-1, 1, 0));
  EXPECT_THROW(foxglove::obstacleScene(a), foxglove::ConversionError);
  a = ellipses();
  a.obstacles()[0].probability_bound(1.0);
  EXPECT_THROW(foxglove::obstacleScene(a), foxglove::ConversionError);
  a = ellipses();
  a.obstacles()[0].orientation(msg::Quaternion{});
  a.obstacles()[0].orientation().w(0);
  EXPECT_THROW(foxglove::obstacleScene(a), foxglove::ConversionError);
  a = ellipses();
  a.header().stamp_ns(-5);
  EXPECT_THROW(foxglove::obstacleScene(a), foxglove::ConversionError);
}

TEST(FoxgloveScenario, DemoYardEveryObstacleDrawn) {
  const auto s = planner::loadScenario(std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml");
  const json m = foxglove::scenarioScene(s, 0);
  expectConforms("foxglove.SceneUpdate", m);
  ASSERT_EQ(m["entities"].size(), 3u);
  const json& obstacles = m["entities"][0];
  EXPECT_EQ(obstacles["id"], "scenario/obstacles");
  EXPECT_EQ(obstacles["cubes"].size() + obstacles["cylinders"].size() + obstacles["spheres"].size(), s.obstacles.size());
  EXPECT_EQ(obstacles["cubes"].size(), 3u);      // the demo yard's three boxes
  EXPECT_EQ(obstacles["cylinders"].size(), 2u);  // a circle and an ellipse, as 2-D walls
  EXPECT_EQ(m["entities"][1]["lines"][0]["points"].size(), 4u);
  // The 3-D terrain world has hills and spheres.
  const auto t = planner::loadScenario(std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/gart_terrain_3d.yaml");
  expectConforms("foxglove.SceneUpdate", foxglove::scenarioScene(t, 0));
}

TEST(FoxglovePath, SolvedLineAndUnsolvedReason) {
  msg::Path p;
  p.header().stamp_ns(5);
  p.planner("gart");
  p.solved(true);
  p.cost(2.5);
  msg::PathState a, b;
  b.x(1), b.y(2);
  p.states({a, b});
  json m = foxglove::pathScene(p);
  expectConforms("foxglove.SceneUpdate", m);
  ASSERT_EQ(m["entities"][0]["lines"][0]["points"].size(), 2u);
  EXPECT_DOUBLE_EQ(m["entities"][0]["lines"][0]["points"][1]["y"], 2.0);

  p.solved(false);
  p.states({});
  p.failure("no path in the budget");
  m = foxglove::pathScene(p);
  expectConforms("foxglove.SceneUpdate", m);
  EXPECT_TRUE(m["entities"][0]["lines"].empty());
  EXPECT_NE(m["entities"][0]["texts"][0]["text"].get<std::string>().find("no path in the budget"), std::string::npos);
}

TEST(FoxgloveTrajectory, SamplesAsLine) {
  msg::Trajectory t;
  t.header().stamp_ns(9);
  for (int i = 0; i < 5; ++i) {
    msg::TrajectorySample s;
    s.position(v3(i, 0.5 * i, 0));
    t.samples().push_back(s);
  }
  const json m = foxglove::trajectoryScene(t);
  expectConforms("foxglove.SceneUpdate", m);
  EXPECT_EQ(m["entities"][0]["lines"][0]["points"].size(), 5u);
  EXPECT_DOUBLE_EQ(m["entities"][0]["lines"][0]["points"][4]["y"], 2.0);
}

TEST(FoxgloveVehicle, TransformAndArrow) {
  const auto s = vehicleAt(1, 2, M_PI / 2, 100);
  const json tf = foxglove::vehicleTransform(s);
  expectConforms("foxglove.FrameTransform", tf);
  EXPECT_EQ(tf["parent_frame_id"], "map");
  EXPECT_EQ(tf["child_frame_id"], "vehicle");
  EXPECT_DOUBLE_EQ(tf["translation"]["y"], 2.0);
  EXPECT_NEAR(tf["rotation"]["z"].get<double>(), std::sqrt(0.5), 1e-12);
  const json scene = foxglove::vehicleScene(s, {v3(0, 0, 0), v3(1, 2, 0)});
  expectConforms("foxglove.SceneUpdate", scene);
  EXPECT_EQ(scene["entities"][0]["arrows"].size(), 1u);
  EXPECT_EQ(scene["entities"][1]["lines"][0]["points"].size(), 2u);
  auto bad = s;
  bad.heading(std::numeric_limits<double>::infinity());
  EXPECT_THROW(foxglove::vehicleTransform(bad), foxglove::ConversionError);
}

TEST(FoxgloveMap, OccupiedLeavesAsCubesAndGridSlice) {
  const auto map = mapWith({{1.25f, 1.25f, 0.25f}, {3.25f, 2.25f, 0.25f}});
  const auto voxels = foxglove::occupiedVoxels(map, 100);
  ASSERT_EQ(voxels.size(), 2u);
  EXPECT_DOUBLE_EQ(voxels[0].size, 0.5);
  const json scene = foxglove::mapScene(map);
  expectConforms("foxglove.SceneUpdate", scene);
  EXPECT_EQ(scene["entities"][0]["cubes"].size(), 2u);
  bool truncated = false;
  EXPECT_EQ(foxglove::occupiedVoxels(map, 1, &truncated).size(), 1u);
  EXPECT_TRUE(truncated);

  const json grid = foxglove::mapGrid(map, 0.25);
  expectConforms("foxglove.Grid", grid);
  ASSERT_EQ(grid["column_count"], 8);
  const auto cells = unbase64(grid["data"]);
  ASSERT_EQ(cells.size(), 64u);
  EXPECT_EQ(static_cast<std::int8_t>(cells[2 * 8 + 2]), 100);  // (1.25, 1.25)
  EXPECT_EQ(static_cast<std::int8_t>(cells[4 * 8 + 6]), 100);  // (3.25, 2.25)
  EXPECT_EQ(static_cast<std::int8_t>(cells[0]), 0);            // the free cell
  EXPECT_EQ(static_cast<std::int8_t>(cells[7 * 8 + 7]), -1);   // never seen
  // Fewer cells allowed: coarser ones.
  EXPECT_EQ(foxglove::mapGrid(map, 0.25, 16)["column_count"], 4);

  auto junk = map;
  junk.octree({1, 2, 3, 4});
  EXPECT_THROW(foxglove::mapScene(junk), foxglove::ConversionError);
  junk.octree({});
  EXPECT_THROW(foxglove::mapScene(junk), foxglove::ConversionError);
}

TEST(FoxgloveDeriver, ChannelsByType) {
  using foxglove::SceneDeriver;
  EXPECT_EQ(SceneDeriver::channelsFor("perception/obstacles", "ddsnav::msg::ObstacleArray"),
            (std::vector<foxglove::DerivedChannel>{{"foxglove/perception/obstacles", "foxglove.SceneUpdate"}}));
  EXPECT_EQ(SceneDeriver::channelsFor("vehicle/state", "ddsnav::msg::VehicleState").size(), 2u);
  EXPECT_EQ(SceneDeriver::channelsFor("map/octomap", "ddsnav::msg::OccupancyMap")[1].schema_name, "foxglove.Grid");
  EXPECT_TRUE(SceneDeriver::channelsFor("system/status", "ddsnav::msg::ComponentStatus").empty());
  EXPECT_TRUE(SceneDeriver().standingChannels().empty());
  SceneDeriver with_scenario({.scenario = planner::loadScenario(std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/demo_2d.yaml")});
  ASSERT_EQ(with_scenario.standingMessages(0).size(), 1u);
  EXPECT_EQ(with_scenario.standingMessages(0)[0].channel.topic, "foxglove/scenario");
}

TEST(FoxgloveDeriver, RawSamplesBecomeDerivedMessages) {
  foxglove::SceneDeriver derive;
  const auto bytes = msg::serializeToBytes(ellipses());
  auto out = derive.onSample("perception/obstacles", "ddsnav::msg::ObstacleArray", bytes);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].channel.topic, "foxglove/perception/obstacles");
  EXPECT_EQ(out[0].stamp_ns, 1'500'000'123);
  expectConforms("foxglove.SceneUpdate", json::parse(out[0].json));

  // Truncated bytes: an error naming the topic and type.
  const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + bytes.size() / 2);
  try {
    derive.onSample("perception/obstacles", "ddsnav::msg::ObstacleArray", cut);
    FAIL() << "truncated payload accepted";
  } catch (const foxglove::ConversionError& e) {
    EXPECT_NE(std::string(e.what()).find("perception/obstacles: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("ObstacleArray"), std::string::npos) << e.what();
  }
  // Bad values are prefixed with the topic too.
  auto bad = ellipses();
  bad.obstacles()[0].semi_axes(v3(-1, 0, 0));
  EXPECT_THROW(derive.onSample("perception/obstacles", "ddsnav::msg::ObstacleArray", msg::serializeToBytes(bad)), foxglove::ConversionError);
  // Types without a view give nothing.
  EXPECT_TRUE(derive.onSample("system/clock", "ddsnav::msg::Clock", bytes).empty());
}

TEST(FoxgloveDeriver, TrackIsSpacedThinnedAndVehicleSceneThrottled) {
  foxglove::SceneDeriverOptions options;
  options.max_track_points = 8;
  options.track_spacing_m = 0.5;
  options.vehicle_scene_period_ns = 100;
  foxglove::SceneDeriver derive(options);
  std::size_t scenes = 0, transforms = 0;
  for (int i = 0; i < 100; ++i) {  // 0.1 m and 50 ns apart: a track point every 5th, a scene every 2nd sample
    for (const auto& m : derive.onSample("vehicle/state", "ddsnav::msg::VehicleState", msg::serializeToBytes(vehicleAt(0.1 * i, 0, 0, 50 * i)))) {
      if (m.channel.schema_name == "foxglove.FrameTransform") ++transforms;
      else {
        ++scenes;
        expectConforms("foxglove.SceneUpdate", json::parse(m.json));
      }
    }
  }
  EXPECT_EQ(transforms, 100u);
  EXPECT_EQ(scenes, 50u);
  EXPECT_LE(derive.track().size(), 8u);
  EXPECT_GE(derive.track().size(), 4u);
  EXPECT_NEAR(derive.track().front().x(), 0.0, 1e-9);  // thinning keeps the start
  EXPECT_GT(derive.track().back().x(), 9.0);           // and the newest point
  // A bad state leaves the track as it was.
  const auto before = derive.track().size();
  EXPECT_THROW(derive.onSample("vehicle/state", "ddsnav::msg::VehicleState",
                               msg::serializeToBytes(vehicleAt(std::nan(""), 0, 0, 99999))),
               foxglove::ConversionError);
  EXPECT_EQ(derive.track().size(), before);
}

TEST(FoxgloveSvg, NewestEntitiesDrawnFromAbove) {
  foxglove::SceneSvg svg;
  svg.add("foxglove/perception/obstacles", foxglove::obstacleScene(ellipses()));
  auto two = ellipses();
  two.obstacles().push_back(two.obstacles()[0]);
  two.obstacles()[1].id(8);
  svg.add("foxglove/perception/obstacles", foxglove::obstacleScene(two));  // deletes all, then two
  EXPECT_EQ(svg.entityCount(), 2u);
  svg.add("foxglove/vehicle/state", foxglove::vehicleScene(vehicleAt(1, 2, 0, 5), {v3(0, 0, 0), v3(1, 2, 0)}));
  EXPECT_EQ(svg.entityCount(), 4u);
  const std::string picture = svg.render("test");
  EXPECT_EQ(picture.rfind("<svg", 0), 0u);
  std::size_t ellipses_drawn = 0;
  for (auto at = picture.find("<ellipse"); at != std::string::npos; at = picture.find("<ellipse", at + 1)) ++ellipses_drawn;
  EXPECT_EQ(ellipses_drawn, 2u);
  EXPECT_NE(picture.find("<polyline"), std::string::npos);  // the track
  EXPECT_NE(picture.find("<line"), std::string::npos);      // the vehicle arrow
  EXPECT_NE(picture.find("rotate(-28.6"), std::string::npos) << "ellipse turned by its yaw (0.5 rad)";
}
