#include <ddsnav/foxglove/scene.hpp>

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <memory>
#include <sstream>

namespace ddsnav::foxglove {
namespace {

using nlohmann::json;

constexpr int kFloat32 = 7;  // foxglove.NumericType
constexpr int kInt8 = 2;
constexpr int kLineStrip = 0, kLineLoop = 1;  // foxglove.LineType
constexpr int kDeleteAll = 1;                 // foxglove.SceneEntityDeletionType

double finite(double v, const std::string& field) {
  if (!std::isfinite(v)) throw ConversionError(field + " is " + std::to_string(v) + ", expected a finite number");
  return v;
}
double nonNegative(double v, const std::string& field) {
  if (finite(v, field) < 0) throw ConversionError(field + " is " + std::to_string(v) + ", expected >= 0");
  return v;
}

json vec(double x, double y, double z) { return {{"x", x}, {"y", y}, {"z", z}}; }
json vec(const msg::Vec3& v, const std::string& field) {
  return vec(finite(v.x(), field + ".x"), finite(v.y(), field + ".y"), finite(v.z(), field + ".z"));
}
json quat(double x, double y, double z, double w) { return {{"x", x}, {"y", y}, {"z", z}, {"w", w}}; }
json yawQuat(double yaw) { return quat(0, 0, std::sin(yaw / 2), std::cos(yaw / 2)); }
json identity() { return quat(0, 0, 0, 1); }
json pose(json position, json orientation) { return {{"position", std::move(position)}, {"orientation", std::move(orientation)}}; }
json rgba(const Rgba& c) { return {{"r", c.r}, {"g", c.g}, {"b", c.b}, {"a", c.a}}; }

const Rgba kObstacleColour{1.0, 0.55, 0.0, 0.45};
const Rgba kTrueObstacleColour{0.45, 0.45, 0.45, 0.8};
const Rgba kPathColour{0.85, 0.1, 0.1, 1.0};
const Rgba kTrajectoryColour{0.1, 0.7, 0.2, 1.0};
const Rgba kTrackColour{0.15, 0.35, 0.95, 1.0};
const Rgba kVehicleColour{0.05, 0.1, 0.6, 1.0};
const Rgba kMapColour{0.3, 0.3, 0.8, 0.6};

// An entity with every primitive list present and empty, as the schema requires.
json entity(const std::string& id, const std::string& frame, std::int64_t stamp_ns) {
  return {{"timestamp", timeOf(stamp_ns)},
          {"frame_id", frame.empty() ? std::string("map") : frame},
          {"id", id},
          {"lifetime", {{"sec", 0}, {"nsec", 0}}},  // 0: until replaced or deleted
          {"frame_locked", false},
          {"metadata", json::array()},
          {"arrows", json::array()},
          {"cubes", json::array()},
          {"spheres", json::array()},
          {"cylinders", json::array()},
          {"lines", json::array()},
          {"triangles", json::array()},
          {"texts", json::array()},
          {"models", json::array()}};
}

void addMetadata(json& e, const std::string& key, const std::string& value) {
  e["metadata"].push_back({{"key", key}, {"value", value}});
}

json line(int type, json points, double thickness, const Rgba& colour) {
  return {{"type", type},
          {"pose", pose(vec(0, 0, 0), identity())},
          {"thickness", thickness},
          {"scale_invariant", false},
          {"points", std::move(points)},
          {"color", rgba(colour)},
          {"colors", json::array()},
          {"indices", json::array()}};
}

json sized(json pose_, json size, const Rgba& colour) {
  return {{"pose", std::move(pose_)}, {"size", std::move(size)}, {"color", rgba(colour)}};
}

json cylinder(json pose_, json size, const Rgba& colour) {
  return {{"pose", std::move(pose_)}, {"size", std::move(size)}, {"bottom_scale", 1.0}, {"top_scale", 1.0},
          {"color", rgba(colour)}};
}

json text(json position, const std::string& s, double font_size = 14) {
  return {{"pose", pose(std::move(position), identity())},
          {"billboard", true},
          {"font_size", font_size},
          {"scale_invariant", true},
          {"color", rgba({1, 1, 1, 1})},
          {"text", s}};
}

json sceneUpdate(json entities, std::int64_t delete_all_at_ns = -1) {
  json deletions = json::array();
  if (delete_all_at_ns >= 0) deletions.push_back({{"timestamp", timeOf(delete_all_at_ns)}, {"type", kDeleteAll}, {"id", ""}});
  return {{"deletions", std::move(deletions)}, {"entities", std::move(entities)}};
}

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

std::unique_ptr<octomap::OcTree> readTree(const msg::OccupancyMap& map) {
  const double res = map.resolution();
  if (!std::isfinite(res) || res <= 0) throw ConversionError("resolution is " + std::to_string(res) + ", expected > 0");
  const auto& bytes = map.octree();
  if (bytes.empty()) throw ConversionError("octree is empty, expected OctoMap binary tree bytes");
  auto tree = std::make_unique<octomap::OcTree>(res);
  std::istringstream in(std::string(bytes.begin(), bytes.end()));
  // The message holds exactly writeBinary(std::ostream&)'s output: a header, then the data.
  // OctoMap reports progress and errors on std::cerr ("Reading binary octree type OcTree", every map);
  // the error is ours to report, once, so its chatter is held back meanwhile (ddsnav logs via spdlog,
  // not std::cerr).
  std::ostringstream octomap_chatter;
  std::streambuf* const cerr_buffer = std::cerr.rdbuf(octomap_chatter.rdbuf());
  const bool read = tree->readBinary(in);
  std::cerr.rdbuf(cerr_buffer);
  if (!read) throw ConversionError("octree: not an OctoMap binary tree (" + std::to_string(bytes.size()) + " bytes)");
  return tree;
}

}  // namespace

json timeOf(std::int64_t stamp_ns) {
  if (stamp_ns < 0) throw ConversionError("stamp_ns is " + std::to_string(stamp_ns) + ", expected >= 0");
  return {{"sec", stamp_ns / 1000000000}, {"nsec", stamp_ns % 1000000000}};
}

std::string base64(const std::uint8_t* data, std::size_t size) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 3 <= size; i += 3) {
    const std::uint32_t v = (data[i] << 16) | (data[i + 1] << 8) | data[i + 2];
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (const std::size_t rest = size - i; rest > 0) {
    const std::uint32_t v = (data[i] << 16) | (rest == 2 ? data[i + 1] << 8 : 0);
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += rest == 2 ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

json pointCloud(const msg::PointCloud& cloud) {
  const auto& xyz = cloud.xyz();
  const auto& intensity = cloud.intensity();
  if (xyz.size() % 3 != 0)
    throw ConversionError("xyz has " + std::to_string(xyz.size()) + " values, expected a multiple of 3");
  const std::size_t n = xyz.size() / 3;
  if (!intensity.empty() && intensity.size() != n)
    throw ConversionError("intensity has " + std::to_string(intensity.size()) + " values for " + std::to_string(n) +
                          " points, expected 0 or one per point");
  const bool with_intensity = !intensity.empty();
  const std::size_t stride = with_intensity ? 16 : 12;
  // Non-finite points are passed on: Foxglove skips them, like the mapper and perception do.
  std::vector<std::uint8_t> packed(n * stride);
  for (std::size_t i = 0; i < n; ++i) {
    std::memcpy(&packed[i * stride], &xyz[3 * i], 12);  // little-endian float32 x, y, z, as Foxglove reads them
    if (with_intensity) std::memcpy(&packed[i * stride + 12], &intensity[i], 4);
  }
  json fields = json::array({{{"name", "x"}, {"offset", 0}, {"type", kFloat32}},
                             {{"name", "y"}, {"offset", 4}, {"type", kFloat32}},
                             {{"name", "z"}, {"offset", 8}, {"type", kFloat32}}});
  if (with_intensity) fields.push_back({{"name", "intensity"}, {"offset", 12}, {"type", kFloat32}});
  return {{"timestamp", timeOf(cloud.header().stamp_ns())},
          {"frame_id", cloud.header().frame_id().empty() ? std::string("map") : cloud.header().frame_id()},
          {"pose", pose(vec(0, 0, 0), identity())},
          {"point_stride", stride},
          {"fields", std::move(fields)},
          {"data", base64(packed.data(), packed.size())}};
}

json obstacleScene(const msg::ObstacleArray& array, double planar_thickness) {
  const std::int64_t stamp = array.header().stamp_ns();
  json entities = json::array();
  const auto& obstacles = array.obstacles();
  for (std::size_t i = 0; i < obstacles.size(); ++i) {
    const auto& o = obstacles[i];
    const std::string field = "obstacles[" + std::to_string(i) + "]";
    const auto& q = o.orientation();
    double qx = finite(q.x(), field + ".orientation.x"), qy = finite(q.y(), field + ".orientation.y");
    double qz = finite(q.z(), field + ".orientation.z"), qw = finite(q.w(), field + ".orientation.w");
    const double norm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    if (norm < 1e-9) throw ConversionError(field + ".orientation is a zero quaternion");
    qx /= norm, qy /= norm, qz /= norm, qw /= norm;
    const double ax = nonNegative(o.semi_axes().x(), field + ".semi_axes.x");
    const double ay = nonNegative(o.semi_axes().y(), field + ".semi_axes.y");
    double az = nonNegative(o.semi_axes().z(), field + ".semi_axes.z");
    const double p = finite(o.probability_bound(), field + ".probability_bound");
    if (p <= 0 || p >= 1) throw ConversionError(field + ".probability_bound is " + std::to_string(p) + ", expected in (0, 1)");
    // A sphere of diameter 1 scaled by the full axis lengths is the ellipsoid; in 2-D a thin disc.
    const double height = array.planar() ? planar_thickness : 2 * az;
    json centre = vec(o.centre(), field + ".centre");
    json e = entity("obstacle/" + std::to_string(o.id()), array.header().frame_id(), stamp);
    e["spheres"].push_back(sized(pose(centre, quat(qx, qy, qz, qw)), vec(2 * ax, 2 * ay, height), kObstacleColour));
    json label_at = centre;
    label_at["z"] = label_at["z"].get<double>() + height / 2 + 0.1;
    e["texts"].push_back(text(label_at, "p " + fixed(p, 2)));
    addMetadata(e, "probability_bound", fixed(p, 4));
    addMetadata(e, "point_count", std::to_string(o.point_count()));
    entities.push_back(std::move(e));
  }
  // The array replaces the previous one whole: obstacle ids are not tracked across arrays.
  return sceneUpdate(std::move(entities), stamp);
}

json scenarioScene(const planner::Scenario& s, std::int64_t stamp_ns) {
  const bool planar = s.dimensions == 2;
  const double wall = 1.0;  // m: how tall 2-D obstacles are drawn
  json obstacles = entity("scenario/obstacles", "map", stamp_ns);
  for (std::size_t i = 0; i < s.obstacles.size(); ++i) {
    const auto& o = s.obstacles[i];
    const double z = planar ? wall / 2 : o.center.z();
    json at = vec(o.center.x(), o.center.y(), z);
    switch (o.type) {
      case planner::ObstacleType::Box:
        obstacles["cubes"].push_back(
            sized(pose(at, yawQuat(o.yaw)), vec(o.size.x(), o.size.y(), planar ? wall : o.size.z()), kTrueObstacleColour));
        break;
      case planner::ObstacleType::Sphere:
        if (planar)
          obstacles["cylinders"].push_back(cylinder(pose(at, identity()), vec(2 * o.radius, 2 * o.radius, wall), kTrueObstacleColour));
        else
          obstacles["spheres"].push_back(sized(pose(at, identity()), vec(2 * o.radius, 2 * o.radius, 2 * o.radius), kTrueObstacleColour));
        break;
      case planner::ObstacleType::Ellipsoid:
        if (planar)
          obstacles["cylinders"].push_back(cylinder(pose(at, yawQuat(o.yaw)),
                                                    vec(2 * o.semi_axes.x(), 2 * o.semi_axes.y(), wall), kTrueObstacleColour));
        else
          obstacles["spheres"].push_back(sized(pose(at, yawQuat(o.yaw)),
                                               vec(2 * o.semi_axes.x(), 2 * o.semi_axes.y(), 2 * o.semi_axes.z()),
                                               kTrueObstacleColour));
        break;
      case planner::ObstacleType::Hill:  // a Gaussian bump: drawn as a cone-like cylinder of its width
        at["z"] = o.height / 2;
        obstacles["cylinders"].push_back({{"pose", pose(at, identity())},
                                          {"size", vec(4 * o.sigma, 4 * o.sigma, o.height)},
                                          {"bottom_scale", 1.0},
                                          {"top_scale", 0.1},
                                          {"color", rgba(kTrueObstacleColour)}});
        break;
    }
  }
  addMetadata(obstacles, "scenario", s.name);
  addMetadata(obstacles, "source", s.source);

  json bounds = entity("scenario/bounds", "map", stamp_ns);
  const auto& lo = s.bounds_min;
  const auto& hi = s.bounds_max;
  const double bz = planar ? 0 : lo.z();
  bounds["lines"].push_back(line(kLineLoop,
                                 json::array({vec(lo.x(), lo.y(), bz), vec(hi.x(), lo.y(), bz), vec(hi.x(), hi.y(), bz),
                                              vec(lo.x(), hi.y(), bz)}),
                                 0.05, {0.8, 0.8, 0.8, 1}));

  json endpoints = entity("scenario/start_goal", "map", stamp_ns);
  endpoints["spheres"].push_back(sized(pose(vec(s.start.x(), s.start.y(), s.start.z()), identity()), vec(0.4, 0.4, 0.4), {0.1, 0.8, 0.1, 1}));
  const double r = std::max(s.goal_radius, 0.1);
  endpoints["cylinders"].push_back(cylinder(pose(vec(s.goal.x(), s.goal.y(), s.goal.z()), identity()),
                                            vec(2 * r, 2 * r, 0.05), {0.9, 0.8, 0.1, 0.6}));
  endpoints["texts"].push_back(text(vec(s.goal.x(), s.goal.y(), s.goal.z() + 0.3), "goal"));
  return sceneUpdate(json::array({std::move(obstacles), std::move(bounds), std::move(endpoints)}));
}

json pathScene(const msg::Path& path) {
  const std::int64_t stamp = path.header().stamp_ns();
  json e = entity("path", path.header().frame_id(), stamp);
  addMetadata(e, "request_id", std::to_string(path.request_id()));
  addMetadata(e, "planner", path.planner());
  if (!path.solved()) {
    addMetadata(e, "failure", path.failure());
    e["texts"].push_back(text(vec(0, 0, 1), "no path (" + path.planner() + "): " + path.failure()));
    return sceneUpdate(json::array({std::move(e)}));
  }
  json points = json::array();
  const auto& states = path.states();
  for (std::size_t i = 0; i < states.size(); ++i) {
    const std::string field = "states[" + std::to_string(i) + "]";
    points.push_back(vec(finite(states[i].x(), field + ".x"), finite(states[i].y(), field + ".y"),
                         finite(states[i].z(), field + ".z")));
  }
  addMetadata(e, "cost", fixed(path.cost(), 3));
  e["lines"].push_back(line(kLineStrip, std::move(points), 0.06, kPathColour));
  return sceneUpdate(json::array({std::move(e)}));
}

json trajectoryScene(const msg::Trajectory& trajectory) {
  json e = entity("trajectory", trajectory.header().frame_id(), trajectory.header().stamp_ns());
  addMetadata(e, "request_id", std::to_string(trajectory.request_id()));
  json points = json::array();
  const auto& samples = trajectory.samples();
  for (std::size_t i = 0; i < samples.size(); ++i) points.push_back(vec(samples[i].position(), "samples[" + std::to_string(i) + "].position"));
  e["lines"].push_back(line(kLineStrip, std::move(points), 0.04, kTrajectoryColour));
  return sceneUpdate(json::array({std::move(e)}));
}

json vehicleScene(const msg::VehicleState& state, const std::vector<msg::Vec3>& track) {
  const std::int64_t stamp = state.header().stamp_ns();
  const double heading = finite(state.heading(), "heading");
  json vehicle = entity("vehicle", state.header().frame_id(), stamp);
  vehicle["arrows"].push_back({{"pose", pose(vec(state.position(), "position"), yawQuat(heading))},
                               {"shaft_length", 0.5},
                               {"shaft_diameter", 0.12},
                               {"head_length", 0.3},
                               {"head_diameter", 0.3},
                               {"color", rgba(kVehicleColour)}});
  json driven = entity("track", state.header().frame_id(), stamp);
  json points = json::array();
  for (std::size_t i = 0; i < track.size(); ++i) points.push_back(vec(track[i], "track[" + std::to_string(i) + "]"));
  driven["lines"].push_back(line(kLineStrip, std::move(points), 0.04, kTrackColour));
  return sceneUpdate(json::array({std::move(vehicle), std::move(driven)}));
}

json vehicleTransform(const msg::VehicleState& state) {
  const double heading = finite(state.heading(), "heading");
  return {{"timestamp", timeOf(state.header().stamp_ns())},
          {"parent_frame_id", state.header().frame_id().empty() ? std::string("map") : state.header().frame_id()},
          {"child_frame_id", kVehicleFrame},
          {"translation", vec(state.position(), "position")},
          {"rotation", yawQuat(heading)}};
}

std::vector<Voxel> occupiedVoxels(const msg::OccupancyMap& map, std::size_t max_voxels, bool* truncated) {
  const auto tree = readTree(map);
  std::vector<Voxel> voxels;
  bool more = false;
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
    if (!tree->isNodeOccupied(*it)) continue;
    if (voxels.size() == max_voxels) {
      more = true;
      break;
    }
    voxels.push_back({it.getX(), it.getY(), it.getZ(), it.getSize()});
  }
  if (truncated) *truncated = more;
  return voxels;
}

json mapScene(const msg::OccupancyMap& map, std::size_t max_voxels) {
  bool truncated = false;
  const auto voxels = occupiedVoxels(map, max_voxels, &truncated);
  json e = entity("map", map.header().frame_id(), map.header().stamp_ns());
  for (const auto& v : voxels) e["cubes"].push_back(sized(pose(vec(v.x, v.y, v.z), identity()), vec(v.size, v.size, v.size), kMapColour));
  addMetadata(e, "occupied_voxels", std::to_string(voxels.size()) + (truncated ? "+ (truncated)" : ""));
  addMetadata(e, "resolution", fixed(map.resolution(), 3));
  return sceneUpdate(json::array({std::move(e)}));
}

json mapGrid(const msg::OccupancyMap& map, double z, std::size_t max_cells) {
  const auto tree = readTree(map);
  const msg::Vec3& lo = map.bounds_min();
  const msg::Vec3& hi = map.bounds_max();
  const double x0 = finite(lo.x(), "bounds_min.x"), y0 = finite(lo.y(), "bounds_min.y");
  const double x1 = finite(hi.x(), "bounds_max.x"), y1 = finite(hi.y(), "bounds_max.y");
  if (x1 < x0 || y1 < y0) throw ConversionError("bounds_max is below bounds_min");
  if (!std::isfinite(z)) throw ConversionError("grid height is not finite");
  if (max_cells == 0) throw ConversionError("max_cells is 0");
  double cell = map.resolution();
  auto count = [&](double extent) { return std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(extent / cell))); };
  while (count(x1 - x0) * count(y1 - y0) > max_cells) cell *= 2;
  const std::size_t columns = count(x1 - x0), rows = count(y1 - y0);
  std::vector<std::uint8_t> cells(columns * rows);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < columns; ++c) {
      const octomap::OcTreeNode* node = tree->search(x0 + (c + 0.5) * cell, y0 + (r + 0.5) * cell, z);
      const std::int8_t value = node == nullptr ? -1 : tree->isNodeOccupied(node) ? 100 : 0;
      cells[r * columns + c] = static_cast<std::uint8_t>(value);
    }
  return {{"timestamp", timeOf(map.header().stamp_ns())},
          {"frame_id", map.header().frame_id().empty() ? std::string("map") : map.header().frame_id()},
          {"pose", pose(vec(x0, y0, z), identity())},
          {"column_count", columns},
          {"cell_size", {{"x", cell}, {"y", cell}}},
          {"row_stride", columns},
          {"cell_stride", 1},
          {"fields", json::array({{{"name", "occupancy"}, {"offset", 0}, {"type", kInt8}}})},
          {"data", base64(cells.data(), cells.size())}};
}

}  // namespace ddsnav::foxglove
