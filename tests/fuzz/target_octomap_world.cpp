// Fuzz target: the map world's reader of OcTree::writeBinary bytes (what map/octomap carries) and the
// queries a planner makes of the world it builds: point, segment, clearance and neighbour queries, perception's
// ellipses clipped to what the map observed (2-D) and a lattice route search. The first input byte picks 2-D or 3-D
// and the unknown-space option, the rest are the octree bytes.
// Contract: std::runtime_error naming makeOctoMapWorld, or a world that answers every query.
#include "fuzz_input.hpp"

#include <ddsnav/planner/coarse_route.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <Eigen/Geometry>

#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace ddsnav::planner;
  if (size == 0) return 0;
  const int dimensions = (data[0] & 1) ? 3 : 2;
  OctoMapWorldOptions options;
  options.unknown_is_occupied = (data[0] & 2) != 0;
  // The components' defaults too: in 3-D solid below the surface with a 1 m margin (its second pass over the
  // free leaves), in 2-D a 1 m unknown margin.
  options.solid_below_surface = (data[0] & 4) != 0;
  options.surface_margin_m = (data[0] & 8) != 0 ? 1.0 : 0.0;
  options.unknown_margin_m = (data[0] & 16) != 0 ? 1.0 : 0.0;
  const std::vector<std::uint8_t> octree(data + 1, data + size);
  // The shipped 2-D demo yard and 3-D terrain: the bounds a planner clips the map to.
  static const Scenario yard = loadScenario(DDSNAV_SOURCE_DIR "/configs/scenarios/demo_2d.yaml");
  static const Scenario terrain = loadScenario(DDSNAV_SOURCE_DIR "/configs/scenarios/gart_terrain_3d.yaml");
  const Scenario& s = dimensions == 3 ? terrain : yard;
  std::unique_ptr<CollisionWorld> world;
  try {
    world = makeOctoMapWorld(s.dimensions, s.bounds_min, s.bounds_max, s.robot_radius, octree, options);
  } catch (const std::runtime_error& e) {
    ddsnav::fuzz::expectNamed(e.what(), "makeOctoMapWorld");
    return 0;
  }
  (void)world->isFree(s.start);
  (void)world->isSegmentFree(s.start, s.goal);
  (void)world->clearance(s.goal);
  (void)world->obstaclesNear(s.start, 2.0);
  // Ellipses at the start, the goal and between them, one tilted: clipped against whatever the bytes made observed.
  std::vector<EllipsoidObstacle> ellipses(3);
  const Vec3 points[3] = {s.start, s.goal, 0.5 * (s.start + s.goal)};
  for (std::size_t i = 0; i < ellipses.size(); ++i) {
    ellipses[i].id = static_cast<int>(i);
    ellipses[i].center = points[i];
    ellipses[i].semi_axes = Vec3(1.5, 0.3, 0.3);
  }
  ellipses[2].axes = Eigen::AngleAxisd(0.7, Vec3::UnitZ()).toRotationMatrix();
  const auto clipped = clipToObservedSpace(*world, ellipses);
  if (clipped.clipped.size() != ellipses.size()) __builtin_trap();
  CoarseRouteOptions lattice;
  lattice.time_limit_s = 0.05;
  (void)findCoarseRoute(*world, s.start, s.goal, s.goal_radius, lattice);
  return 0;
}
