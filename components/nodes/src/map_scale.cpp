#include "ddsnav/nodes/map_scale.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::nodes {

namespace {
constexpr double kFinestResolution = 0.1;   // m
constexpr double kVoxelsPerRadius = 5.0;
constexpr double kMaxVoxelsPerBeam = 300.0;
// 2-D: a scanner casts hundreds of beams, not a 3-D lidar's tens of thousands, so 1 000 voxels per beam costs
// less than 300 do in 3-D. A 30 m map of a 66 m scanner left walls 30-66 m away out of the map while perception
// leaves walls longer than structure_extent_m to the map: nothing blocked them (bugtrap_1.0, 2026-12-03: plans
// through the trap's far walls, the vehicle driving into the trap's far corner).
constexpr double kMaxVoxelsPerBeam2d = 1000.0;
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
  out.max_range = std::min(range, (scenario.dimensions == 3 ? kMaxVoxelsPerBeam : kMaxVoxelsPerBeam2d) * out.resolution);
  return out;
}

namespace {
double radiusOf(const planner::Scenario& scenario) {
  return std::isfinite(scenario.robot_radius) && scenario.robot_radius > 0 ? scenario.robot_radius : 0.0;
}
}  // namespace

double defaultStructureExtent(const planner::Scenario& scenario) { return std::min(10.0, 25.0 * radiusOf(scenario)); }
double defaultUnknownMargin(const planner::Scenario& scenario) { return std::min(1.0, 2.0 * radiusOf(scenario)); }

double defaultHiddenContinuation(const planner::Scenario& scenario) { return std::min(15.0, 30.0 * radiusOf(scenario)); }

}  // namespace ddsnav::nodes
