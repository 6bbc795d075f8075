#pragma once
// Which range sensor the simulator mounts on a scenario's vehicle. The scenario format has no sensor
// block, so every field the user leaves unset is derived from the scenario (docs/simulator.md, "Which
// sensor"):
//
//   kind       3-D world: 3-D lidar. 2-D world whose larger horizontal side is >= 500 m (sea scale):
//              forward-looking sonar. Any other 2-D world: 360-degree planar scanner.
//   max_range  max(reaction, extent / 10), at most 200 m and at most the horizontal diagonal, where
//              reaction = 10 s * v_max + 2 * v_max / omega_max (ten seconds of travel at top speed plus the
//              diameter of the tightest turn) and extent the larger horizontal side of the bounds.
//   fov        scanner and lidar 360 degrees; sonar 130 degrees centred on the heading.
//   beams      one every 0.5 degrees for the scanner and the sonar (perception's default beam spacing);
//              the lidar has 512 columns and 16 rings (more where they would be over 3.4 degrees apart, at most
//              24) over +-h degrees, h the vehicle's steepest climb atan(vz_max / v_max) + 3 degrees, rounded up,
//              within [15, 45] (defaultLidarHalfFovDeg, defaultLidarRings).
//
//   sim::SensorRequest request;            // all unset: the default for the scenario
//   request.max_range = 80.0;              // the user's override
//   const sim::SensorChoice choice = sim::chooseSensor(scenario, request);
//   sim::RangeSensor sensor(scenario, choice.config);
//
// Errors: std::invalid_argument naming the field as the user spells it (max_range, fov_deg, ...), e.g. a
// range of 0 or an empty field of view: a sensor that cannot see anything is refused, not simulated.

#include <ddsnav/planner/scenario.hpp>
#include <ddsnav/sim/range_sensor.hpp>

#include <optional>
#include <string>

namespace ddsnav::sim {

enum class SensorKind { Scanner, Lidar, Sonar };

// "scanner", "lidar", "sonar".
std::string sensorKindName(SensorKind kind);
// Accepts the names above and "auto" (nullopt). Throws std::invalid_argument for anything else.
std::optional<SensorKind> parseSensorKind(const std::string& name);

// The user's choices; nullopt fields take the scenario's default.
struct SensorRequest {
  std::optional<SensorKind> kind;
  std::optional<double> max_range;         // m
  std::optional<double> fov_deg;           // horizontal field of view, centred on the heading
  std::optional<int> beams;                // horizontal beams (a lidar's columns)
  std::optional<int> rings;                // lidar / 3-D sonar only
  std::optional<double> vertical_min_deg;  // lidar / 3-D sonar only
  std::optional<double> vertical_max_deg;
};

struct SensorChoice {
  SensorKind kind = SensorKind::Scanner;
  RangeSensorConfig config;
  // One line for the log: kind, range, field of view, beams, and which of them came from the rule.
  std::string summary;
};

// The default range for `scenario` (the rule at the top); 0 inputs never give 0: at least 1 m.
double defaultMaxRange(const planner::Scenario& scenario);
// The default kind for `scenario` (the rule at the top).
SensorKind defaultSensorKind(const planner::Scenario& scenario);

// The default 3-D lidar's vertical half field of view, degrees: the vehicle's steepest climb (atan(vz_max / v_max))
// + 3, rounded up, within [15, 45]; 15 without a vehicle block.
double defaultLidarHalfFovDeg(const planner::Scenario& scenario);

// The default 3-D lidar's rings over a vertical span (degrees): 16, or more where 16 would be over 3.4 degrees apart,
// at most 24.
int defaultLidarRings(double vertical_span_deg);

// The sensor for `scenario` with `request` applied. Throws std::invalid_argument naming the bad field.
// Noise, invalid returns, walls and seed keep RangeSensorConfig's defaults; the caller sets them.
SensorChoice chooseSensor(const planner::Scenario& scenario, const SensorRequest& request = {});

}  // namespace ddsnav::sim
