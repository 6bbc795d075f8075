// Scenario YAML reader (format: ../shared/scenario-format.md). Every check happens here, once, so the
// rest of the planner can trust a Scenario: finite numbers, non-degenerate bounds, known keys only.

#include "ddsnav/planner/scenario.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <set>
#include <sstream>
#include <string>

namespace ddsnav::planner {
namespace {

// Carries the file name so every error can say "FILE:LINE: key 'K': ...".
class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key, const std::string& what) const {
    std::ostringstream out;
    out << source_;
    const YAML::Mark mark = at.Mark();
    if (mark.line >= 0) out << ':' << (mark.line + 1);
    out << ": key '" << key << "': " << what;
    throw ScenarioError(out.str());
  }

  // The map must contain only `allowed` keys, each at most once.
  void checkKeys(const YAML::Node& map, const std::string& where, std::initializer_list<const char*> allowed) const {
    if (!map.IsMap()) fail(map, where.empty() ? "<document>" : where, "expected a mapping");
    std::set<std::string> seen;
    for (const auto& entry : map) {
      if (!entry.first.IsScalar()) fail(entry.first, where, "expected a plain key");
      const std::string key = entry.first.Scalar();
      bool known = false;
      for (const char* a : allowed) known = known || key == a;
      if (!known) {
        std::string list;
        for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        fail(entry.first, qualified(where, key), "unknown key (expected one of: " + list + ")");
      }
      if (!seen.insert(key).second) fail(entry.first, qualified(where, key), "duplicate key");
    }
  }

  YAML::Node require(const YAML::Node& map, const std::string& where, const std::string& key) const {
    const YAML::Node node = map[key];
    if (!node) fail(map, qualified(where, key), "missing (required)");
    return node;
  }

  double number(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) fail(node, key, "expected a number");
    double value = 0.0;
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      fail(node, key, "expected a number, got '" + node.Scalar() + "'");
    }
    if (!std::isfinite(value)) fail(node, key, "expected a finite number, got '" + node.Scalar() + "'");
    return value;
  }

  double positive(const YAML::Node& node, const std::string& key) const {
    const double value = number(node, key);
    if (value <= 0.0) fail(node, key, "expected a positive number, got " + node.Scalar());
    return value;
  }

  double nonNegative(const YAML::Node& node, const std::string& key) const {
    const double value = number(node, key);
    if (value < 0.0) fail(node, key, "expected a number >= 0, got " + node.Scalar());
    return value;
  }

  std::string text(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) fail(node, key, "expected a string");
    return node.Scalar();
  }

  // A list of exactly `count` finite numbers (or, when allow_extra, count + 1).
  std::vector<double> numbers(const YAML::Node& node, const std::string& key, std::size_t count,
                              bool allow_extra = false) const {
    const std::string expected = allow_extra ? std::to_string(count) + " or " + std::to_string(count + 1)
                                             : std::to_string(count);
    if (!node.IsSequence()) fail(node, key, "expected a list of " + expected + " numbers");
    if (node.size() != count && !(allow_extra && node.size() == count + 1)) {
      fail(node, key, "expected " + expected + " numbers, got " + std::to_string(node.size()));
    }
    std::vector<double> values;
    for (std::size_t i = 0; i < node.size(); ++i) values.push_back(number(node[i], key + "[" + std::to_string(i) + "]"));
    return values;
  }

  Vec3 vector(const YAML::Node& node, const std::string& key, int dimensions) const {
    const auto v = numbers(node, key, static_cast<std::size_t>(dimensions));
    return Vec3(v[0], v[1], dimensions == 3 ? v[2] : 0.0);
  }

  static std::string qualified(const std::string& where, const std::string& key) {
    return where.empty() ? key : where + "." + key;
  }

 private:
  std::string source_;
};

Obstacle readObstacle(const Reader& in, const YAML::Node& node, const std::string& where, int dimensions) {
  if (!node.IsMap()) in.fail(node, where, "expected a mapping like {type: box, ...}");
  const std::string type = in.text(in.require(node, where, "type"), where + ".type");
  auto key = [&](const char* k) { return where + "." + k; };
  Obstacle obstacle;
  if (type == "box") {
    obstacle.type = ObstacleType::Box;
    if (node["min"] || node["max"]) {
      in.checkKeys(node, where, {"type", "min", "max"});
      const Vec3 lo = in.vector(in.require(node, where, "min"), key("min"), dimensions);
      const Vec3 hi = in.vector(in.require(node, where, "max"), key("max"), dimensions);
      for (int i = 0; i < dimensions; ++i) {
        if (!(hi[i] > lo[i])) in.fail(node["max"], key("max"), "every entry must be greater than the same entry of min");
      }
      obstacle.center = 0.5 * (lo + hi);
      obstacle.size = hi - lo;
    } else {
      in.checkKeys(node, where, {"type", "center", "size", "yaw"});
      obstacle.center = in.vector(in.require(node, where, "center"), key("center"), dimensions);
      const YAML::Node size = in.require(node, where, "size");
      obstacle.size = in.vector(size, key("size"), dimensions);
      for (int i = 0; i < dimensions; ++i) {
        if (!(obstacle.size[i] > 0.0)) in.fail(size, key("size"), "every entry must be positive");
      }
      if (node["yaw"]) obstacle.yaw = in.number(node["yaw"], key("yaw"));
    }
  } else if (type == "sphere") {
    obstacle.type = ObstacleType::Sphere;
    in.checkKeys(node, where, {"type", "center", "radius"});
    obstacle.center = in.vector(in.require(node, where, "center"), key("center"), dimensions);
    obstacle.radius = in.positive(in.require(node, where, "radius"), key("radius"));
  } else if (type == "ellipsoid") {
    obstacle.type = ObstacleType::Ellipsoid;
    in.checkKeys(node, where, {"type", "center", "semi_axes", "yaw"});
    obstacle.center = in.vector(in.require(node, where, "center"), key("center"), dimensions);
    const YAML::Node axes = in.require(node, where, "semi_axes");
    obstacle.semi_axes = in.vector(axes, key("semi_axes"), dimensions);
    for (int i = 0; i < dimensions; ++i) {
      if (!(obstacle.semi_axes[i] > 0.0)) in.fail(axes, key("semi_axes"), "every entry must be positive");
    }
    if (node["yaw"]) obstacle.yaw = in.number(node["yaw"], key("yaw"));
  } else if (type == "hill") {
    obstacle.type = ObstacleType::Hill;
    if (dimensions != 3) in.fail(node["type"], key("type"), "a hill is 3-D terrain; this scenario has dimensions: 2");
    in.checkKeys(node, where, {"type", "center", "height", "sigma"});
    const auto c = in.numbers(in.require(node, where, "center"), key("center"), 2);
    obstacle.center = Vec3(c[0], c[1], 0.0);
    obstacle.height = in.positive(in.require(node, where, "height"), key("height"));
    obstacle.sigma = in.positive(in.require(node, where, "sigma"), key("sigma"));
  } else {
    in.fail(node["type"], key("type"), "unknown obstacle type '" + type + "' (expected box, sphere, ellipsoid or hill)");
  }
  return obstacle;
}

VehicleLimits readVehicle(const Reader& in, const YAML::Node& node, int dimensions) {
  // vz_max is a known key in 2-D too (the format's own 2-D example carries it, marked "3-D only"): it is
  // checked like any number and then has no effect, since a planar vehicle does not climb.
  in.checkKeys(node, "vehicle", {"model", "v_max", "omega_max", "vz_max", "dt"});
  VehicleLimits vehicle;
  if (node["model"]) {
    vehicle.model = in.text(node["model"], "vehicle.model");
    if (vehicle.model != "unicycle") in.fail(node["model"], "vehicle.model", "unknown model '" + vehicle.model + "' (expected unicycle)");
  }
  vehicle.v_max = in.positive(in.require(node, "vehicle", "v_max"), "vehicle.v_max");
  vehicle.omega_max = in.positive(in.require(node, "vehicle", "omega_max"), "vehicle.omega_max");
  // Without an explicit climb rate the vehicle climbs as fast as it drives.
  const double vz_max = node["vz_max"] ? in.nonNegative(node["vz_max"], "vehicle.vz_max") : vehicle.v_max;
  vehicle.vz_max = dimensions == 3 ? vz_max : 0.0;
  if (node["dt"]) vehicle.dt = in.positive(node["dt"], "vehicle.dt");
  return vehicle;
}

Scenario readScenario(const YAML::Node& root, const std::string& source) {
  const Reader in(source);
  if (!root || root.IsNull()) throw ScenarioError(source + ": key '<document>': the scenario is empty");
  in.checkKeys(root, "", {"name", "dimensions", "bounds", "robot_radius", "start", "goal", "goal_radius", "vehicle", "obstacles"});

  Scenario s;
  s.source = source;
  s.name = root["name"] ? in.text(root["name"], "name") : std::filesystem::path(source).stem().string();

  const YAML::Node dims = in.require(root, "", "dimensions");
  const double d = in.number(dims, "dimensions");
  if (d != 2.0 && d != 3.0) in.fail(dims, "dimensions", "expected 2 or 3, got " + dims.Scalar());
  s.dimensions = static_cast<int>(d);

  const YAML::Node bounds = in.require(root, "", "bounds");
  in.checkKeys(bounds, "bounds", {"min", "max"});
  s.bounds_min = in.vector(in.require(bounds, "bounds", "min"), "bounds.min", s.dimensions);
  s.bounds_max = in.vector(in.require(bounds, "bounds", "max"), "bounds.max", s.dimensions);
  for (int i = 0; i < s.dimensions; ++i) {
    if (!(s.bounds_max[i] > s.bounds_min[i])) {
      in.fail(bounds["max"], "bounds.max", "degenerate bounds: every entry of max must be greater than the same entry of min");
    }
  }

  if (root["robot_radius"]) s.robot_radius = in.nonNegative(root["robot_radius"], "robot_radius");

  auto inside = [&](const Vec3& p) {
    for (int i = 0; i < s.dimensions; ++i) {
      if (p[i] < s.bounds_min[i] || p[i] > s.bounds_max[i]) return false;
    }
    return true;
  };

  const YAML::Node start = in.require(root, "", "start");
  const auto sv = in.numbers(start, "start", static_cast<std::size_t>(s.dimensions), s.dimensions == 2);
  s.start = Vec3(sv[0], sv[1], s.dimensions == 3 ? sv[2] : 0.0);
  if (sv.size() == 3 && s.dimensions == 2) s.start_heading = sv[2];
  if (!inside(s.start)) in.fail(start, "start", "outside bounds");

  const YAML::Node goal = in.require(root, "", "goal");
  s.goal = in.vector(goal, "goal", s.dimensions);
  if (!inside(s.goal)) in.fail(goal, "goal", "outside bounds");

  s.goal_radius = in.positive(in.require(root, "", "goal_radius"), "goal_radius");

  if (root["vehicle"]) s.vehicle = readVehicle(in, root["vehicle"], s.dimensions);

  if (const YAML::Node obstacles = root["obstacles"]; obstacles && !obstacles.IsNull()) {
    if (!obstacles.IsSequence()) in.fail(obstacles, "obstacles", "expected a list");
    if (obstacles.size() > kMaxScenarioObstacles)
      in.fail(obstacles, "obstacles",
              std::to_string(obstacles.size()) + " obstacles, more than the limit of " + std::to_string(kMaxScenarioObstacles) +
                  " (kMaxScenarioObstacles)");
    for (std::size_t i = 0; i < obstacles.size(); ++i) {
      s.obstacles.push_back(readObstacle(in, obstacles[i], "obstacles[" + std::to_string(i) + "]", s.dimensions));
    }
  }
  return s;
}

}  // namespace

static std::string tooLarge(const std::string& source_name, std::size_t bytes) {
  return source_name + ": key '<file>': " + std::to_string(bytes) + " bytes, larger than the limit of " +
         std::to_string(kMaxScenarioFileBytes) + " bytes for a scenario (kMaxScenarioFileBytes)";
}

Scenario parseScenario(const std::string& yaml_text, const std::string& source_name) {
  if (yaml_text.size() > kMaxScenarioFileBytes) throw ScenarioError(tooLarge(source_name, yaml_text.size()));
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw ScenarioError(source_name + ":" + std::to_string(e.mark.line + 1) + ": key '<syntax>': " + e.msg);
  }
  return readScenario(root, source_name);
}

Scenario loadScenario(const std::string& path) {
  // Kind and size before reading: a FIFO would block, a huge file would be parsed whole.
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status)) throw ScenarioError(path + ": key '<file>': cannot open the scenario file");
  if (!std::filesystem::is_regular_file(status)) throw ScenarioError(path + ": key '<file>': not a regular file");
  const auto size = std::filesystem::file_size(path, error);
  if (!error && size > kMaxScenarioFileBytes) throw ScenarioError(tooLarge(path, size));
  std::ifstream file(path);
  if (!file) throw ScenarioError(path + ": key '<file>': cannot open the scenario file");
  std::string text(kMaxScenarioFileBytes + 1, '\0');
  file.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(file.gcount()));
  if (text.size() > kMaxScenarioFileBytes) throw ScenarioError(tooLarge(path, text.size()));
  return parseScenario(text, path);
}

}  // namespace ddsnav::planner
