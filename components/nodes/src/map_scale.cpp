#include "ddsnav/nodes/map_scale.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::nodes {

namespace {
constexpr double kFinestResolution = 0.1;   // m
constexpr double kVoxelsPerRadius = 5.0;
constexpr double kMaxVoxelsPerBeam = 300.0;
}  // namespace

MapScale mapScaleFor(const planner::Scenario& scenario, double sensor_range) {
  MapScale out;
  const double radius = std::isfinite(scenario.robot_radius) ? scenario.robot_radius : 0.0;
  out.resolution = std::max(kFinestResolution, radius / kVoxelsPerRadius);
  const double range = std::isfinite(sensor_range) && sensor_range > 0 ? sensor_range : out.max_range;
  out.max_range = std::min(range, kMaxVoxelsPerBeam * out.resolution);
  return out;
}

}  // namespace ddsnav::nodes
