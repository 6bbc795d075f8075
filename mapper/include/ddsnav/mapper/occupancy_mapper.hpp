#pragma once
// The mapper library: an OctoMap OcTree built from range scans, exported as OcTree::writeBinary bytes
// (what the map/octomap message carries and the planner's OctoMap collision world reads).
//
// Insertion gives exactly the tree OctoMap's OcTree::insertPointCloud(cloud, origin, max_range) builds
// (same log-odds in every voxel, same pruned structure), only faster: ray keys are computed on several
// threads, de-duplicated in a flat brick bitmap instead of a std::unordered_set, and applied to the
// tree in Morton order in one walk that shares the path between neighbouring voxels. docs/mapper.md
// explains why the result is identical.

#include <array>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace octomap {
class OcTree;
}

namespace ddsnav::mapper {

struct Point3f {
  float x = 0.0f, y = 0.0f, z = 0.0f;
};

// One scan in the world (map) frame: the measured end points and the sensor origin they were seen from.
struct Scan {
  std::vector<Point3f> points;
  Point3f origin;
  // Points farther than this from the origin only clear space up to max_range (a "no return" beam).
  // Must be > 0; +infinity means no limit.
  double max_range = 20.0;
};

enum class InsertMethod {
  kFast,     // ours: parallel ray keys + brick bitmap de-duplication + one Morton-ordered tree walk
  kOctoMap,  // OcTree::insertPointCloud itself (the reference; lazy_eval = false)
};

struct MapperConfig {
  double resolution = 0.1;  // m, edge of the finest voxel
  int dimensions = 3;       // 2: every point and the origin are put on one z slab at slab_z
  double slab_z = 0.0;      // 2-D: height of the single voxel layer
  // OctoMap's sensor model (its defaults).
  double prob_hit = 0.7;
  double prob_miss = 0.4;
  double occupancy_threshold = 0.5;
  double clamping_min = 0.1192;
  double clamping_max = 0.971;
  // Use the voxel centres of the end points instead of the points (OctoMap's `discretize` flag): faster
  // for dense clouds, slightly different free space. The reference is insertPointCloud(..., discretize).
  bool discretize = false;
  InsertMethod method = InsertMethod::kFast;
  // Threads for the ray keys and the tree walk; the tree is the same for any count. The library's default
  // is 1 (a caller may have its own threads); the mapper component uses 2 (parameter `threads`): on 2 cores a
  // 64x1800 scan at 0.2 m takes about half the time (docs/benchmarks/mapper.md).
  int threads = 1;
  // Pipelined insertion (kFast): insert() computes the scan's ray keys, hands the tree update to a
  // background thread and returns; the update runs while the next scan's keys are computed, and every
  // read of the map (octree(), exportMap(), writeBt(), memoryUsage()) first waits for it. The tree is
  // the same as without pipelining. Uses one more thread than `threads` (the tree thread).
  bool pipeline = false;
  std::size_t max_points = 4'000'000;  // larger scans are rejected, not truncated
  // A beam that returns nothing leaves no point, so the space it crossed stayed unknown — a 2.4 m corridor
  // looked down end-on, onto open space, was never observed free, and the planner's unknown margin closed it
  // (docs/world-model.md, "Beams that return nothing"). With this on, every gap in the scan's bearings wider than
  // 3.5 of its angular step (three beams missing: fewer are invalid returns; the step is the 10th percentile of the
  // gaps between neighbouring bearings) and at most max_clear_gap_rad is filled with rays at that step, ending in no
  // occupied cell and cleared to twice the farther of the returns bounding the gap (at most max_range), in the scan's
  // own insertion (a voxel one of its returns hit stays a hit). A wider gap (a field of view's blind sector, or open space on a side) stays unknown. In 3-D the
  // returns are grouped into the lidar's rings (one elevation each, seen from the origin) and each ring's gaps are
  // cleared so: a window in a wall is then observed free along the rings through it (a cloud of more than 256
  // elevations is not a ring scan and gets none). Off by default: the tree then is exactly OctoMap's
  // insertPointCloud of the points.
  bool clear_beam_gaps = false;
  double max_clear_gap_rad = 0.35;  // 20 degrees
  // 2-D: a face seen at a grazing angle is hit by neighbouring beams metres apart (a corridor's wall 20 m ahead,
  // every 2.5-7 m), and a planner takes the unseen stretches between the hits for open space — and plans through
  // the wall (docs/world-model.md, "Faces seen at a grazing angle"). With this on, the segment between two
  // neighbouring returns (one angular step apart) is marked occupied, with no ray, when both lie on one surface —
  // each on the line of its own neighbours (its range within half the resolution of where its beam meets the line),
  // or with no return beyond it to test, and one at least on the line — and it is at most max_surface_fill_m long
  // (0: the scan's max_range / 8), and so is the segment moved one voxel away from the scanner (the face's far side: rays grazing
  // the face on their way to farther hits observe the voxels it cuts through free). Only voxels never observed are
  // filled, this scan's rays included: a voxel a beam once saw through is never filled again, and a filled one takes
  // one hit, so a few beams through it clear it. An opening between two such hits is one no beam saw through: when
  // one does, its return breaks the line and the fill stops there. Off by default (OctoMap's insertPointCloud).
  bool fill_surfaces_between_returns = false;
  double max_surface_fill_m = 0.0;
  // exportMap(): a region of open air (16 voxels a side, no occupied voxel in it or in a region beside it) whose only
  // change since its last walk is never-observed voxels now observed free keeps its last walk for up to this many
  // exports before it is walked again; any other change of class (a voxel that turns occupied, or free from
  // occupied), and new free space near a mapped surface (a window's inside, under an overhang), is exported at once.
  // The export is then the live tree's maximum likelihood with some newly observed free space in open air not yet in
  // it (as unknown), for at most this many exports. Why: a moving lidar's sparse far rays find new free voxels in most
  // regions they cross on every scan, and walking those again every time was most of the mapper's export
  // (docs/benchmarks/mapper.md, 2026-12-08). 0 (the library's default): every export is exactly OctoMap's writeBinary
  // of the live tree.
  int free_discovery_delay_exports = 0;
  // With a delay: free space found within this distance of the scan's origin (on each axis) is exported at once as
  // well — rays are dense there, and what the vehicle is about to fly through (a window it looks into) is there.
  double free_discovery_near_range_m = 0.0;
};

// Empty when the config is valid, else one message naming the parameter and what was expected.
std::string validateConfig(const MapperConfig& config);

struct InsertResult {
  bool inserted = false;      // false: the scan was rejected (see message), the map is unchanged
  std::string message;        // why it was rejected, or what was cleaned (empty when nothing to say)
  std::size_t points_used = 0;
  std::size_t dropped_non_finite = 0;
  std::size_t gap_rays = 0;        // rays added through the gaps between returns (clear_beam_gaps)
  std::size_t surface_fill = 0;    // points marked occupied between returns on one surface (fill_surfaces_between_returns)
  std::size_t free_cells = 0;      // distinct voxels updated as free (kFast only)
  std::size_t occupied_cells = 0;  // distinct voxels updated as occupied (kFast only)
  double seconds = 0.0;
  // kFast only: where the time went (ray keys on all threads; merge + sort; tree walk).
  // Pipelined: seconds_tree is the previous scan's tree update (it ran during this scan's ray keys) and
  // seconds_wait the time this call waited for it to finish.
  double seconds_rays = 0.0, seconds_merge = 0.0, seconds_tree = 0.0, seconds_wait = 0.0;
  int walk_threads = 0;  // threads that applied the updates to the tree (subtrees split between them)
};

// What the map/octomap message carries.
struct ExportedMap {
  // OcTree::writeBinary's bytes: the maximum-likelihood tree, pruned (eight leaves of one class are their parent);
  // the binary format carries only each leaf's class, so a reader gets the same map as from the whole tree.
  std::vector<std::uint8_t> octree_binary;
  double resolution = 0.0;
  int dimensions = 3;
  std::array<double, 3> bounds_min{0, 0, 0};  // metric bounds of the known voxels (zero when empty)
  std::array<double, 3> bounds_max{0, 0, 0};
  std::size_t leaf_count = 0;  // leaves of that pruned tree
};

class OccupancyMapper {
 public:
  // Throws std::invalid_argument with validateConfig's message.
  explicit OccupancyMapper(const MapperConfig& config);
  ~OccupancyMapper();
  OccupancyMapper(const OccupancyMapper&) = delete;
  OccupancyMapper& operator=(const OccupancyMapper&) = delete;

  // Never throws for bad scans: rejects them (NaN/inf origin, origin outside the map, max_range <= 0 or
  // NaN, more than max_points) or cleans them (non-finite points dropped) and says so in the result.
  InsertResult insert(const Scan& scan);

  // True when an insertion updated at least one voxel since the last exportMap(), or when free space observed
  // before it is still left out of the export (free_discovery_delay_exports).
  bool changedSinceExport() const;
  // Clears the changed flag. `complete`: no region's walk is put off (free_discovery_delay_exports): the bytes are
  // exactly OctoMap's writeBinary of the live tree's maximum likelihood (a last map, a saved one).
  ExportedMap exportMap(bool complete = false);

  // Writes the map as a .bt file (OcTree::writeBinaryConst). Throws std::runtime_error naming the path.
  void writeBt(const std::string& path) const;

  // Waits for a pipelined tree update first (as do exportMap, writeBt and memoryUsage).
  const octomap::OcTree& octree() const;
  // Waits until every inserted scan is in the tree (a no-op without pipelining).
  void finish() const;
  const MapperConfig& config() const { return config_; }
  // Bytes held: the octree (OcTree::memoryUsage) plus the insertion scratch buffers kept between scans.
  std::size_t memoryUsage() const;
  std::size_t scratchMemoryUsage() const;

 private:
  struct Impl;
  MapperConfig config_;
  std::unique_ptr<Impl> impl_;
  bool changed_ = false;
};

// Exactly the bytes of OcTree::writeBinaryConst (the .bt format), without OctoMap's debug output.
void writeOctreeBinary(const octomap::OcTree& tree, std::ostream& out);

// Sets prob_hit/miss, occupancy threshold and clamping on a tree the way MapperConfig describes.
void applySensorModel(octomap::OcTree& tree, const MapperConfig& config);

}  // namespace ddsnav::mapper
