#include "ddsnav/sim/sensor_choice.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <spdlog/fmt/fmt.h>

namespace ddsnav::sim {
namespace {

// The rule's constants (sensor_choice.hpp, docs/simulator.md).
constexpr double kSeaScaleExtent = 500.0;    // m: a 2-D world at least this large is taken to be at sea
constexpr double kReactionTime = 10.0;       // s of travel at top speed the sensor should cover
constexpr double kExtentShare = 0.1;         // the sensor sees at least this share of the world's extent
constexpr double kLongestRange = 200.0;      // m: the longest default (perception's default max_range too)
constexpr double kShortestRange = 1.0;       // m
constexpr double kBeamStepDeg = 0.5;         // perception's default beam spacing (2 pi / 720)
constexpr double kSonarFovDeg = 130.0;
constexpr double kSonar3dApertureDeg = 20.0;  // vertical aperture of a 3-D sonar fan, centred on the horizon
constexpr int kSonar3dRings = 8;
// The 3-D lidar: 16 rings x 512 columns (2 degrees x 0.7 degrees) still put several beams on a 10 m hill
// flank at the default range; 32 x 1024 made the simulator, perception and the mapper fall behind
// simulated time four to one (gart_terrain_3d ran at speed 0.6 when asked for 4).
constexpr int kLidarColumns = 512;
// Its vertical field of view covers the steepest climb the vehicle flies, atan(vz_max / v_max), and a few degrees
// more, at least +-15 degrees and at most +-45; 16 rings (2 degrees apart at +-15), more only where they would be more
// than 3.4 degrees apart (at most 24). Why the fan: the planner and the tracker block space outside it near the vehicle
// (it sees nothing there, docs/world-model.md), so with +-15 degrees a vehicle that climbs at 22-34 degrees climbed
// at 15 at most near itself. An A/B at speed 4 (+-25 degrees, 26 rings; docs/benchmarks/mission.md 2026-12-06 18:2x-20:xx)
// took r3d_42 from 2.07x and 1.33x to 1.07x and 1.05x, and a 12 x 10 x 6 m world climbing at 27 degrees from not
// reached and 0.90x to 1.08x and 1.02x. Why so few rings: 26 rings doubled the map's latency at real time
// (cloud -> map median 140 ms against 80-96 with 16 over the same fan; gart_terrain_3d 1.13x and 1.21x with p99 167
// and 206 ms from obstacles to trajectory, 1.10x and 0.99x with p99 121 and 125 ms with 16).
constexpr double kLidarMinHalfFovDeg = 15.0;
constexpr double kLidarMaxHalfFovDeg = 45.0;
constexpr double kClimbViewMarginDeg = 3.0;
constexpr double kLidarWidestRingStepDeg = 3.4;
constexpr int kLidarMinRings = 16;
constexpr int kLidarMaxRings = 24;

double horizontalExtent(const planner::Scenario& s) {
  return std::max(s.bounds_max.x() - s.bounds_min.x(), s.bounds_max.y() - s.bounds_min.y());
}

double horizontalDiagonal(const planner::Scenario& s) {
  return std::hypot(s.bounds_max.x() - s.bounds_min.x(), s.bounds_max.y() - s.bounds_min.y());
}

void require(bool ok, const std::string& field, const std::string& expected, const std::string& got) {
  if (!ok) throw std::invalid_argument(fmt::format("parameter {}: expected {}, got {}", field, expected, got));
}

// Beams every kBeamStepDeg across `fov_deg` (a full circle has no beam on its seam twice).
int beamsFor(double fov_deg) {
  if (fov_deg >= 360.0) return static_cast<int>(std::lround(360.0 / kBeamStepDeg));
  return static_cast<int>(std::lround(fov_deg / kBeamStepDeg)) + 1;
}

}  // namespace

double defaultLidarHalfFovDeg(const planner::Scenario& scenario) {
  double climb_deg = 0.0;
  if (scenario.vehicle && scenario.vehicle->v_max > 0.0 && scenario.vehicle->vz_max > 0.0)
    climb_deg = std::atan2(scenario.vehicle->vz_max, scenario.vehicle->v_max) * 180.0 / std::numbers::pi;
  const double half = std::clamp(climb_deg + kClimbViewMarginDeg, kLidarMinHalfFovDeg, kLidarMaxHalfFovDeg);
  return std::isfinite(half) ? std::ceil(half) : kLidarMinHalfFovDeg;
}

int defaultLidarRings(double vertical_span_deg) {
  const double rings = std::ceil(vertical_span_deg / kLidarWidestRingStepDeg - 1e-9) + 1.0;
  return std::isfinite(rings) ? static_cast<int>(std::clamp(rings, double(kLidarMinRings), double(kLidarMaxRings))) : kLidarMinRings;
}

std::string sensorKindName(SensorKind kind) {
  switch (kind) {
    case SensorKind::Scanner: return "scanner";
    case SensorKind::Lidar: return "lidar";
    case SensorKind::Sonar: return "sonar";
  }
  return "?";
}

std::optional<SensorKind> parseSensorKind(const std::string& name) {
  if (name == "auto") return std::nullopt;
  if (name == "scanner") return SensorKind::Scanner;
  if (name == "lidar") return SensorKind::Lidar;
  if (name == "sonar") return SensorKind::Sonar;
  throw std::invalid_argument("sensor: expected auto, scanner, lidar or sonar, got '" + name + "'");
}

SensorKind defaultSensorKind(const planner::Scenario& scenario) {
  if (scenario.dimensions == 3) return SensorKind::Lidar;
  return horizontalExtent(scenario) >= kSeaScaleExtent ? SensorKind::Sonar : SensorKind::Scanner;
}

double defaultMaxRange(const planner::Scenario& scenario) {
  double reaction = 0.0;
  if (scenario.vehicle) {
    const auto& v = *scenario.vehicle;
    reaction = kReactionTime * v.v_max;
    if (v.omega_max > 0.0) reaction += 2.0 * v.v_max / v.omega_max;
  }
  const double range = std::max(reaction, kExtentShare * horizontalExtent(scenario));
  const double cap = std::min(kLongestRange, horizontalDiagonal(scenario));
  const double chosen = std::min(range, cap);
  return std::isfinite(chosen) ? std::max(chosen, kShortestRange) : kShortestRange;
}

SensorChoice chooseSensor(const planner::Scenario& scenario, const SensorRequest& request) {
  const bool planar = scenario.dimensions == 2;
  SensorChoice choice;
  choice.kind = request.kind.value_or(defaultSensorKind(scenario));
  if (planar && choice.kind == SensorKind::Lidar)
    throw std::invalid_argument("sensor: scenario '" + scenario.name + "' is 2-D: expected scanner or sonar, got lidar");
  if (!planar && choice.kind == SensorKind::Scanner)
    throw std::invalid_argument("sensor: scenario '" + scenario.name + "' is 3-D: expected lidar or sonar, got scanner");

  const double range = request.max_range.value_or(defaultMaxRange(scenario));
  require(std::isfinite(range) && range > 0.0 && range <= 1e5, "max_range", "a range in (0, 1e5] m (0 sees nothing)",
          fmt::format("{}", range));
  const double fov = request.fov_deg.value_or(choice.kind == SensorKind::Sonar ? kSonarFovDeg : 360.0);
  require(std::isfinite(fov) && fov > 0.0 && fov <= 360.0, "fov_deg", "a field of view in (0, 360] degrees (0 sees nothing)",
          fmt::format("{}", fov));
  const int beams = request.beams.value_or(beamsFor(fov));
  require(beams >= 1 && beams <= (1 << 16), "beams", "[1, 65536]", std::to_string(beams));
  if (planar && (request.rings || request.vertical_min_deg || request.vertical_max_deg))
    throw std::invalid_argument("sensor: scenario '" + scenario.name +
                                "' is 2-D: its sensor is planar, so rings and vertical_*_deg do not apply");

  RangeSensorConfig config;
  if (planar) {
    config = RangeSensorConfig::scanner2d(beams, range);
  } else if (choice.kind == SensorKind::Lidar) {
    const double half = defaultLidarHalfFovDeg(scenario);
    const double low = request.vertical_min_deg.value_or(-half), high = request.vertical_max_deg.value_or(half);
    config = RangeSensorConfig::lidar3d(request.rings.value_or(defaultLidarRings(high - low)), request.beams.value_or(kLidarColumns),
                                        low, high, range);
  } else {
    config = RangeSensorConfig::lidar3d(request.rings.value_or(kSonar3dRings), beams,
                                        request.vertical_min_deg.value_or(-0.5 * kSonar3dApertureDeg),
                                        request.vertical_max_deg.value_or(0.5 * kSonar3dApertureDeg), range);
  }
  config.horizontal_fov_deg = fov;
  require(config.rings >= 1 && config.rings <= 4096, "rings", "[1, 4096]", std::to_string(config.rings));
  require(std::isfinite(config.vertical_min_deg) && config.vertical_min_deg >= -90.0, "vertical_min_deg", "[-90, 90] degrees",
          fmt::format("{}", config.vertical_min_deg));
  require(std::isfinite(config.vertical_max_deg) && config.vertical_max_deg <= 90.0 &&
              config.vertical_max_deg >= config.vertical_min_deg,
          "vertical_max_deg", "[vertical_min_deg, 90] degrees", fmt::format("{}", config.vertical_max_deg));
  require(range > config.min_range, "max_range", fmt::format("more than the minimum range {} m", config.min_range),
          fmt::format("{}", range));
  config.validate();

  auto origin = [](bool given) { return given ? "set" : "default"; };
  choice.summary = fmt::format("{} ({}), range {:.1f} m ({}), field of view {:g} deg ({}), {} beams{}", sensorKindName(choice.kind),
                               origin(request.kind.has_value()), range, origin(request.max_range.has_value()), fov,
                               origin(request.fov_deg.has_value()), config.columns,
                               planar ? std::string() : fmt::format(" x {} rings over [{:g}, {:g}] deg", config.rings,
                                                                    config.vertical_min_deg, config.vertical_max_deg));
  choice.config = config;
  return choice;
}

}  // namespace ddsnav::sim
