#pragma once
// What a planner (or smoother) may ask of the world. Three implementations sit behind it:
// exact scenario geometry, a set of obstacle ellipses/ellipsoids (perception), and an OctoMap (mapper).
// The robot radius is part of the world: isFree(p) means "a disc/ball of robot_radius at p is inside the
// bounds and touches no obstacle".

#include "ddsnav/planner/scenario.hpp"

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace ddsnav::planner {

// An obstacle seen from a query point, for planners that use contact information (GART, RRRT, APGD).
struct NearbyObstacle {
  int id = -1;                 // stable within one world
  Vec3 nearest_point;          // closest point of the obstacle's surface to the query point
  double distance = 0.0;       // from the query point to nearest_point (0 when inside)
};

class CollisionWorld {
 public:
  virtual ~CollisionWorld() = default;

  virtual int dimensions() const = 0;
  virtual Vec3 boundsMin() const = 0;
  virtual Vec3 boundsMax() const = 0;
  virtual double robotRadius() const = 0;

  // A robot-sized disc/ball centred at p is inside the bounds and collision free.
  virtual bool isFree(const Vec3& p) const = 0;

  // Every state on the straight segment a-b is free. Implementations check at a step no larger than
  // checkResolution(), and always check both ends.
  virtual bool isSegmentFree(const Vec3& a, const Vec3& b) const;

  // Distance from the robot's boundary to the nearest obstacle (negative when penetrating);
  // bounds are not obstacles here.
  virtual double clearance(const Vec3& p) const = 0;

  // Obstacles whose surface is within `range` of p, nearest first.
  virtual std::vector<NearbyObstacle> obstaclesNear(const Vec3& p, double range) const = 0;

  // obstaclesNear with a voxel map's voxels reduced to the nearest one of each 8x8x8-voxel brick (an OctoMap
  // world's ids are brick * 512 + bit; the same entries, in the same order, as the first of each brick in
  // obstaclesNear's list), nearest first; worlds of other shapes: obstaclesNear. The fused world's query
  // (makeFusedWorld): a wall or the unknown margin within a planner's detection range holds thousands of
  // voxels, and listing and sorting every one of them for each candidate was most of a bug-trap solve.
  // Wrappers forward it.
  virtual std::vector<NearbyObstacle> nearestPerBrick(const Vec3& p, double range) const { return obstaclesNear(p, range); }

  // Step used by isSegmentFree; small enough for the narrowest shipped passage (0.3 m tunnel).
  virtual double checkResolution() const { return check_resolution_; }
  void setCheckResolution(double r) { check_resolution_ = r; }

  // Count of isFree evaluations (segment checks count each sampled state): the "validity checks" metric.
  std::uint64_t validityChecks() const { return checks_.load(std::memory_order_relaxed); }
  void resetValidityChecks() { checks_.store(0, std::memory_order_relaxed); }

 protected:
  void countCheck(std::uint64_t n = 1) const { checks_.fetch_add(n, std::memory_order_relaxed); }

 private:
  double check_resolution_ = 0.05;
  mutable std::atomic<std::uint64_t> checks_{0};
};

// The free position nearest to `p` within `max_distance` (inside the bounds, isFree), searched on a lattice of
// `step` around p (a disc in 2-D, a ball in 3-D; z is kept in 2-D), nearest first; p itself when it is free;
// none when no lattice point is. For a start that a map puts "in collision" because the robot stands right
// next to a surface it has mapped (a hit marks its whole voxel, range noise moves it): planning from there is
// planning from one small step away from that surface, on its near side — unlike clearing the voxels around
// the robot, which opens a hole in a one-voxel-thick surface that a plan can pass through
// (docs/world-model.md, "A start the map puts in collision"). std::invalid_argument for a non-finite p, a
// negative or non-finite max_distance, a step that is not positive and finite, or a lattice of more than
// 1e6 points.
//
// With `wanted_clearance` > 0 a moved position is the nearest whose clearance is at least that, searched up to
// that much farther than the nearest free one (clearance grows at most as fast as the distance), and the nearest
// free one when none is: a start barely free sits on the edge of the map's voxels, where the first edge of any
// path from it grazes them (gart_terrain_3d: a vehicle stopped against a hill had ten plans from 0.25 m away,
// each refused by the smoother, "passes too close to an obstacle" 0.4 m from the vehicle).
//
// With `escape_length` > 0 a moved position must also lead out: a straight free segment that long leaves it along
// one of the lattice's directions (8 in 2-D, 26 in 3-D), tested on the nearest 100 free positions at most. A map's
// widened terrain can leave a free pocket of a few centimetres next to a buried start (r3d_53: a vehicle 0.5 m above
// a 40-degree flank, moved 0.38 m into a pocket from which no edge was free; 1.9 M iterations and no path in 5 s, ten
// times). When no position within reach leads out, the answer is as without it.
std::optional<Vec3> nearestFreePosition(const CollisionWorld& world, const Vec3& p, double max_distance, double step,
                                        double wanted_clearance = 0.0, double escape_length = 0.0);

// The smallest clearance along the segment a-b is at least `required` (true when required <= 0). Clearance is
// 1-Lipschitz, so a point with clearance c vouches for everything within c - required of it: long free stretches take
// few queries, and stretches near the required clearance take one per checkResolution().
bool segmentClearanceAtLeast(const CollisionWorld& world, const Vec3& a, const Vec3& b, double required);

// Exact geometry of a scenario's obstacles.
std::unique_ptr<CollisionWorld> makeScenarioWorld(const Scenario& scenario);

// An ellipse/ellipsoid per obstacle (what perception publishes), inside the given bounds.
struct EllipsoidObstacle {
  int id = -1;
  Vec3 center = Vec3::Zero();
  Vec3 semi_axes = Vec3::Zero();                     // along the columns of `axes`
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // orthonormal, columns are the principal axes
};
std::unique_ptr<CollisionWorld> makeEllipsoidWorld(int dimensions, const Vec3& bounds_min, const Vec3& bounds_max,
                                                   double robot_radius, std::vector<EllipsoidObstacle> obstacles);

// An OctoMap octree serialised with OcTree::writeBinary (the map/octomap message's bytes).
// Throws std::runtime_error when the bytes are not a binary octree.
std::unique_ptr<CollisionWorld> makeOctoMapWorld(int dimensions, const Vec3& bounds_min, const Vec3& bounds_max,
                                                 double robot_radius, const std::vector<std::uint8_t>& octree_binary);

// How the OctoMap world treats voxels the map has never observed (not in the octree). Optimistic planning
// (unknown = free, the default) plans through unexplored space and relies on replanning as the map grows;
// unknown = occupied keeps every state inside observed free space. It affects isFree (and so segment
// checks) only: clearance and obstaclesNear always report observed occupied voxels. In 2-D a column
// counts as occupied / known when any voxel of the octree in that (x, y) cell is.
//
// Work and memory are bounded: leaves are clipped to where they can matter (occupied ones to the bounds
// widened by robot_radius + outside_bounds_margin_m — clearance and obstaclesNear are exact up to that
// distance outside the bounds, and see nothing beyond it; free ones — used by unknown_is_occupied and the 2-D
// unknown margin, and in 3-D where surface_margin_m would block — to the bounds widened by the radius + 2 voxels), and a map that needs more than max_bricks 8x8x8-voxel
// bricks there is refused (std::runtime_error naming the limit). Each brick takes ~180 bytes with its
// hash slots, so the default cap holds the world under ~100 MB; a mapper's map of a shipped scenario
// needs a few thousand bricks (occupied surfaces only), a coarse hostile leaf filling the bounds may not.
inline constexpr std::size_t kOctoMapWorldMaxBricks = std::size_t(1) << 19;  // 2^28 voxels
struct OctoMapWorldOptions {
  bool unknown_is_occupied = false;
  // 3-D only: a point below the highest observed occupied voxel of its (x, y) column is blocked, unknown or
  // not. A lidar sees a terrain's surface and never its inside; optimistic planning would fly through a hill
  // once past its mapped skin (a trajectory into it stays "free" beyond the one-voxel shell, so a replan
  // check that sees the shell late sees nothing ahead). The price: the space under an overhang (a floating
  // obstacle's underside) counts as solid too, as in a 2.5-D elevation map. clearance() is then negative
  // below a column's top, by the depth below it.
  bool solid_below_surface = false;
  // With solid_below_surface: a column counts as high as the highest observed surface within this horizontal
  // distance (a square window), i.e. observed terrain is widened by it below its top. A lidar samples a steep
  // flank only along its rings (2 deg apart: 0.7 m at 20 m), so the skin under a path that skims the flank is
  // often unsampled until the vehicle is a few metres away; the margin makes the sampled skin uphill of the path
  // block it from afar. It yields to space observed free: a point above its own column's surface is not blocked by a
  // neighbour's when its voxel and the robot radius under it (a voxel at least) were observed free — a gap between
  // walls narrower than twice the margin stays open where the lidar saw through it (the free voxels under the
  // margin are loaded in a second pass over the octree). 0: each column only by its own voxels.
  double surface_margin_m = 0.0;
  // With solid_below_surface, when wider than surface_margin_m: a second widening, of the same tops and yielding to
  // space observed free the same way, which only the view makeWiderMarginView plans with (a planner's preferred world;
  // docs/world-model.md, "Seen flanks that go on out of sight (3-D)"). Built in the same pass: the column grid and the
  // free voxels loaded reach this far. 0: none.
  double wider_surface_margin_m = 0.0;
  // 2-D only: a never-observed cell within this distance of an observed occupied cell is blocked. A scanner sees a
  // surface's near side only; the part it has not seen yet continues from the part it has (a circle's far side
  // bulges out beyond its seen arc, a wall goes on past its seen end), and a path hugging the seen part into that
  // unknown space was found blocked only once the vehicle was too close (docs/world-model.md). It also closes
  // unseen passages narrower than twice the margin plus the robot, so the planner uses it as a preference: it
  // plans on the plain map when it finds no path with it. 0: off.
  double unknown_margin_m = 0.0;
  // Load the free leaves even when nothing above needs them, so that clipToObservedSpace knows which cells were
  // observed free (2-D; a 3-D map's free leaves fill the whole observed volume and are not kept for it).
  bool keep_observed_free = false;
  double outside_bounds_margin_m = 5.0;
  std::size_t max_bricks = kOctoMapWorldMaxBricks;
};
std::unique_ptr<CollisionWorld> makeOctoMapWorld(int dimensions, const Vec3& bounds_min, const Vec3& bounds_max,
                                                 double robot_radius, const std::vector<std::uint8_t>& octree_binary,
                                                 const OctoMapWorldOptions& options);

// The map world `map` (makeOctoMapWorld, 3-D, built with wider_surface_margin_m) with its columns widened by that
// wider margin instead of surface_margin_m: isFree and clearance use the wider tops; the rest is the map's. Shares the
// map (no copy, no build). Null when `map` is not such a world.
std::shared_ptr<const CollisionWorld> makeWiderMarginView(std::shared_ptr<const CollisionWorld> map);

// Where seen surfaces probably go on, out of sight (docs/world-model.md, "Seen surfaces that go on out of sight"). A
// 2-D scanner sees the near face of a wall up to where something in front hides it; optimistic planning then
// takes the hidden stretch as open and plans through it (bugtrap_0.6: the box's side wall behind the neck, the
// vehicle driven 15 m the wrong way before it saw it). For every observed occupied cell that ends a straight run of
// them (the principal axis of those within 0.5 m, 9x longer than wide, none beyond it along the axis) and is in
// sight from `viewpoint`, the cells on along that axis that were never observed and are hidden from the viewpoint
// (an observed occupied cell lies between) are returned, up to max_length_m; the first observed cell, or the first
// one in plain sight, ends the run. (An end out of sight may be a true end seen earlier from elsewhere.) Empty unless
// `world` is a 2-D makeOctoMapWorld built knowing its unobserved cells (unknown_margin_m > 0 or unknown_is_occupied).
// At most 2^20 cells.
struct OccludedContinuation {
  std::vector<Vec3> cells;  // cell centres (z = 0)
  double cell_size = 0.0;   // m, the map's resolution
};
OccludedContinuation occludedSurfaceContinuation(const CollisionWorld& world, const Vec3& viewpoint, double max_length_m);
// Does now the part of occludedSurfaceContinuation that depends on the map alone (where its seen surfaces end), which the
// first continuation asked of `world` would do otherwise; nothing for a world that is not such a map. Thread-safe.
void prepareSurfaceContinuation(const CollisionWorld& world);

// Perception's ellipses against what a 2-D map has seen (docs/world-model.md, "Ellipses of mapped surfaces"). An
// ellipse whose axis the map holds as observed occupied cells — within two cells of its centre and of one of the points
// half its major semi-axis either side — bounds a piece of surface the map has mapped too; past the ends of the
// stretch of its major axis the map's occupied cells inside it span, the part the scanner's rays crossed (cells
// observed free) holds nothing, so it is clipped: replaced there by the cells it overlaps that were not observed
// free (what lies hidden) or that border an observed occupied cell. Along the stretch it keeps its whole width
// (rays grazing a surface clear the surface's own cells between the hits the map keeps). An ellipse the
// map does not hold yet (an obstacle that just appeared, a curved one whose centre lies off its arc) stays whole. Nothing is clipped unless `world` is a 2-D
// makeOctoMapWorld that loaded its free leaves (keep_observed_free, unknown_margin_m > 0 or unknown_is_occupied), nor
// an ellipse wider than 2^16 cells.
struct ClippedObstacles {
  std::vector<Vec3> cells;      // the clipped ellipses' remaining cells (centres, z = 0)
  double cell_size = 0.0;       // m, the map's resolution
  std::vector<bool> clipped;    // per ellipse: true when its cells replace it
};
ClippedObstacles clipToObservedSpace(const CollisionWorld& world, const std::vector<EllipsoidObstacle>& ellipses);

// Whether the robot's disc at `p` lies in space a 2-D map has observed free: every cell within the robot radius
// less half a cell of `p` was crossed by a ray and holds no hit. For the tracker's speed bound (docs/tracking.md,
// "Stopping within observed space"): optimistic planning plans through space nobody has seen, and the vehicle must
// still be able to stop before it gets there. std::nullopt when `world` cannot tell: not a 2-D makeOctoMapWorld
// that loaded its free leaves (keep_observed_free, unknown_margin_m > 0 or unknown_is_occupied), a disc of more
// than 2^16 cells, or a non-finite p.
std::optional<bool> robotInObservedFreeSpace(const CollisionWorld& world, const Vec3& p);

// `base` with the given cells (squares of cell_size centred on the points, in the x-y plane; z ignored) blocked as
// well: a robot overlapping one is not free, and its clearance counts them. For occludedSurfaceContinuation's and
// clipToObservedSpace's cells.
std::unique_ptr<CollisionWorld> makeBlockedCellsWorld(std::shared_ptr<const CollisionWorld> base, std::vector<Vec3> cells,
                                                      double cell_size);

}  // namespace ddsnav::planner

namespace ddsnav::planner {

// One world from two sources (`world: fused`, docs/world-model.md): static structure and the known/unknown
// split from the mapper's OctoMap (`structure`, built once per map and shared between snapshots), and the
// discrete obstacles perception tracks as probability-p ellipses/ellipsoids (`obstacles`, one per snapshot).
// A state is free only when both say so; clearance is the smaller of the two; obstaclesNear merges both
// lists, nearest first, with ids kept distinct (2k for the structure's id k, 2k + 1 for obstacle id k);
// from an OctoMap structure it takes the nearest voxel per 8x8x8-voxel brick, not every voxel.
// How unknown space counts is the structure's policy (UnknownSpace below, applied when it is built).
// Both must have the same dimensions, bounds and robot radius (std::invalid_argument otherwise).
enum class UnknownSpace {
  Optimistic,    // never-observed voxels are free: plan through them, replan when they are seen occupied
  Conservative,  // never-observed voxels are occupied: only observed free space is used
};
// "optimistic" | "conservative"; std::invalid_argument naming the accepted values otherwise.
UnknownSpace parseUnknownSpace(const std::string& text);
const char* toString(UnknownSpace policy);

std::unique_ptr<CollisionWorld> makeFusedWorld(std::shared_ptr<const CollisionWorld> structure,
                                               std::unique_ptr<CollisionWorld> obstacles);

// What a sensor with a limited vertical field of view (a 3-D lidar's fan) cannot see from where it is:
// within `range` (horizontal distance) of `origin`, the points more than `slack` above the fan's upper edge
// or below its lower one. docs/world-model.md, "Above and below the lidar's fan".
struct SensorView {
  Vec3 origin = Vec3::Zero();     // the sensor (the vehicle) now
  double vertical_min_deg = -15;  // the fan's lower edge, degrees from the horizontal (> -90)
  double vertical_max_deg = 15;   // its upper edge (> vertical_min_deg, < 90)
  double range = 0;               // m; beyond it nothing is blocked (the map's reach: the optimistic policy)
  double slack = 0;               // m; vertical allowance at the apex (the robot, its tracking error)
  bool below = true;              // false: only the space above the fan is unseen
  // A ball never counted unseen: the goal region, so that a goal below the fan of a vehicle flying high is
  // still a goal (the final approach is the map's to judge). Radius 0: none.
  Vec3 exempt_center = Vec3::Zero();
  double exempt_radius = 0;
  // True when p lies in the unseen space: 0 < horizontal distance <= range, above / below the fan by more
  // than slack, and outside the exempt ball.
  bool unseen(const Vec3& p) const;
};
// `world` with the unseen space of `view` blocked (isFree, isSegmentFree; clearance and obstaclesNear are the
// world's: it is no obstacle, only space nothing vouches for). 3-D only: std::invalid_argument otherwise, or for
// a view with non-finite or inconsistent numbers.
std::unique_ptr<CollisionWorld> makeSensorViewWorld(std::unique_ptr<CollisionWorld> world, const SensorView& view);

}  // namespace ddsnav::planner
