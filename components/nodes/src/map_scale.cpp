#include "ddsnav/nodes/map_scale.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::nodes {

namespace {
constexpr double kFinestResolution = 0.1;   // m
constexpr double kVoxelsPerRadius = 5.0;
constexpr double kMaxVoxelsPerBeam = 300.0;
constexpr double kCoarsestVoxelsPerRadius = 2.0;  // 3-D: a voxel diagonal (0.87 of a voxel) stays under half the radius
}  // namespace

MapScale mapScaleFor(const planner::Scenario& scenario, double sensor_range) {
  MapScale out;
  const double radius = std::isfinite(scenario.robot_radius) ? scenario.robot_radius : 0.0;
  out.resolution = std::max(kFinestResolution, radius / kVoxelsPerRadius);
  const double range = std::isfinite(sensor_range) && sensor_range > 0 ? sensor_range : out.max_range;
  // 3-D: voxels coarse enough for the whole range in 300 per beam, up to half the robot radius — a terrain
  // flank seen only at the end of a 30 m map was seen too late (docs/world-model.md, "The map's scale").
  if (scenario.dimensions == 3)
    out.resolution = std::max(out.resolution, std::min(range / kMaxVoxelsPerBeam, radius / kCoarsestVoxelsPerRadius));
  out.max_range = std::min(range, kMaxVoxelsPerBeam * out.resolution);
  return out;
}

}  // namespace ddsnav::nodes
