#pragma once
// The planning world, as read from a scenario file (see ../shared/scenario-format.md).
// Positions are always 3-vectors; in a 2-D scenario z is 0 and ignored.

#include <Eigen/Core>

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ddsnav::planner {

using Vec3 = Eigen::Vector3d;

enum class ObstacleType { Box, Sphere, Ellipsoid, Hill };

// One obstacle primitive, normalised: every box is stored as centre + full size + yaw
// (an axis-aligned {min, max} box becomes yaw = 0).
struct Obstacle {
  ObstacleType type = ObstacleType::Box;
  Vec3 center = Vec3::Zero();
  Vec3 size = Vec3::Zero();       // box: full edge lengths (z unused in 2-D)
  Vec3 semi_axes = Vec3::Zero();  // ellipsoid: semi-axes (z unused in 2-D)
  double radius = 0.0;            // sphere / circle
  double yaw = 0.0;               // box, ellipsoid: rotation about z, radians CCW from +x
  double height = 0.0;            // hill: peak height (3-D only)
  double sigma = 0.0;             // hill: Gaussian width
};

// Unicycle limits: x' = v cos(theta), y' = v sin(theta), theta' = omega, z' = vz.
struct VehicleLimits {
  std::string model = "unicycle";
  double v_max = 0.0;      // m/s
  double omega_max = 0.0;  // rad/s
  double vz_max = 0.0;     // m/s, 3-D only
  double dt = 1.0;         // forward-extension horizon of one tree edge, s
};

struct Scenario {
  std::string name;
  std::string source;  // file the scenario was read from ("<string>" when parsed from text)
  int dimensions = 2;
  Vec3 bounds_min = Vec3::Zero();
  Vec3 bounds_max = Vec3::Zero();
  double robot_radius = 0.0;
  Vec3 start = Vec3::Zero();
  std::optional<double> start_heading;  // radians; 2-D only
  Vec3 goal = Vec3::Zero();
  double goal_radius = 0.0;
  std::optional<VehicleLimits> vehicle;
  std::vector<Obstacle> obstacles;
};

// Thrown for every malformed scenario. what() reads "FILE:LINE: key 'K': what was expected".
class ScenarioError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Limits checked before any parsing work: the largest shipped scenario is ~6 KB with 80 obstacles, so
// these leave paper-scale worlds (thousands of obstacles) far below them while a 59 MB file is refused
// at once instead of taking gigabytes and minutes in the YAML parser.
inline constexpr std::size_t kMaxScenarioFileBytes = 4 << 20;
inline constexpr std::size_t kMaxScenarioObstacles = 50000;

Scenario loadScenario(const std::string& path);

// The heading the vehicle starts with: the scenario's, else facing the goal.
double startHeading(const Scenario& scenario);
Scenario parseScenario(const std::string& yaml_text, const std::string& source_name = "<string>");

}  // namespace ddsnav::planner
