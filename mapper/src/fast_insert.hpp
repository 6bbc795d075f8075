#pragma once
// Exactly OcTree::insertPointCloud(cloud, origin, max_range, lazy_eval = false, discretize), faster.
//
// OctoMap's insertion spends its time in two places: inserting every ray cell into a std::unordered_set
// (KeySet), and descending the tree from the root for every distinct voxel (twice: search() then
// updateNodeRecurs()). Here:
//   1. Ray keys come from a copy of OcTree::computeRayKeys (statement for statement, same float/double
//      precision, same tie-breaking), run on contiguous runs of points taken by each thread.
//   2. Each thread marks the keys in its own BrickMap: a flat open-addressing hash of 8x8x8-voxel bricks,
//      each holding a free and an occupied bitmask. Neighbouring ray cells land in the same brick, so most
//      marks are one compare with the cached brick and one OR.
//   3. The thread maps are OR-ed together, free &= ~occupied (OctoMap: occupied wins within a scan), and
//      the bricks sorted by Morton code. Iterating the bits of Morton-sorted bricks visits voxels in the
//      octree's depth-first order, so one walk keeps the current root-to-leaf path and only re-descends
//      below the deepest ancestor shared with the previous voxel. A node is finished (pruned when its 8
//      children are equal leaves, else given the max of its children) when the walk leaves its subtree,
//      i.e. after its last update — which is the state OctoMap's non-lazy insertion leaves behind. With
//      several threads, whole subtrees below a split depth are walked in parallel.
// Each voxel receives exactly one update per scan in both, so the visiting order does not change any
// log-odds value; docs/mapper.md has the full argument and the tests compare whole trees byte for byte.

#include <octomap/OcTree.h>

#include <array>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace ddsnav::mapper::detail {

// Voxel keys as 48-bit Morton codes: bit 3i of the code is bit i of the x key, 3i+1 of y, 3i+2 of z (OctoMap's
// child numbering at every level). The code of a key's 8x8x8 brick is then code >> 9, its place inside the
// brick code & 511, and codes in ascending order visit voxels in the octree's depth-first order.
std::uint64_t mortonCode(const octomap::OcTreeKey& key);

// The insertion reports which regions — cubes of 16 voxels a side, the tree's nodes at depth 12 — had a voxel change
// class (unknown, free, occupied: what the maximum-likelihood map shows), so the mapper's export re-walks only
// those (OccupancyMapper::exportMap). A region is named by the Morton prefix of its voxels.
constexpr int kChangeRegionDepth = 12;
constexpr unsigned kChangeRegionShift = 3u * (16u - kChangeRegionDepth);
inline std::uint64_t changeRegionOf(std::uint64_t voxel_morton) { return voxel_morton >> kChangeRegionShift; }
// A reported region with this bit set had only never-observed voxels observed free (a region name has at most 36
// bits): the export may put its walk off (MapperConfig::free_discovery_delay_exports). A region with any other change
// of class is reported without it, and may be reported both ways.
constexpr std::uint64_t kFreeDiscoveryOnly = std::uint64_t(1) << 63;
// The regions that share a face with `region`; at the edge of the key space `region` itself stands for a missing one.
std::array<std::uint64_t, 6> faceNeighbourRegions(std::uint64_t region);

// The voxels one scan updates, as bitmasks over 8x8x8 bricks.
class BrickMap {
 public:
  struct Brick {
    std::uint64_t free[8];
    std::uint64_t occupied[8];
    std::uint64_t fill[8];  // the surface fill (surface_cells of computeKeys), updated by fillUpdate
    std::uint64_t morton;  // Morton code of the brick coordinates (key >> 3 on each axis)
    std::uint16_t bx, by, bz;
  };
  // The brick a stream of marks touched last: neighbouring ray cells mostly share it, so a mark is usually
  // one compare and one OR.
  struct Cursor {
    std::uint64_t brick_code = ~0ull;  // no brick has this code (codes have 39 bits)
    std::uint32_t brick = 0;
  };

  void clear();
  void markFree(std::uint64_t code, Cursor& cursor) { mark(code, false, cursor); }
  void markOccupied(const octomap::OcTreeKey& key) { mark(mortonCode(key), true, cursor_); }
  void markFill(const octomap::OcTreeKey& key) {
    const std::uint64_t code = mortonCode(key);
    const unsigned bit = static_cast<unsigned>(code & 511);
    bricks_[findOrAdd(code >> 9)].fill[bit >> 6] |= 1ull << (bit & 63);
    cursor_ = Cursor{};
  }
  void mergeFrom(const BrickMap& other);

  const std::vector<Brick>& bricks() const { return bricks_; }
  std::vector<Brick>& bricks() { return bricks_; }
  std::size_t memoryUsage() const;

 private:
  void mark(std::uint64_t code, bool occupied, Cursor& cursor) {
    const std::uint64_t brick_code = code >> 9;
    if (brick_code != cursor.brick_code) {
      cursor.brick = findOrAdd(brick_code);
      cursor.brick_code = brick_code;
    }
    Brick& b = bricks_[cursor.brick];
    const unsigned bit = static_cast<unsigned>(code & 511);
    (occupied ? b.occupied : b.free)[bit >> 6] |= 1ull << (bit & 63);
  }
  std::uint32_t findOrAdd(std::uint64_t brick_code);
  void grow();

  std::vector<std::uint64_t> slot_keys_;     // brick Morton codes, kEmpty when unused
  std::vector<std::uint32_t> slot_bricks_;   // index into bricks_
  std::vector<Brick> bricks_;
  Cursor cursor_;  // of markOccupied (the end points), which has no cursor of its own
};

struct InsertCounts {
  std::size_t free_cells = 0;
  std::size_t occupied_cells = 0;
  double seconds_rays = 0.0;   // ray keys + de-duplication (parallel part)
  double seconds_merge = 0.0;  // merging the thread maps, occupied-wins, Morton sort
  double seconds_tree = 0.0;   // the tree walk (pipelined: the previous scan's background walk, if any, plus
                               // this scan's when it was walked at once)
  double seconds_wait = 0.0;   // pipelined: waiting for the previous scan's tree walk after our keys
  int walk_threads = 0;        // threads that walked the tree (1 when the scan was small or not splittable)
};

// Which new free space the change report tags kFreeDiscoveryOnly: only voxels farther than `near_keys` keys (on any
// axis) from the scan's origin; nearer ones are reported as any other change (0: none is nearer).
struct FreeDiscoveryRule {
  octomap::OcTreeKey origin{0, 0, 0};  // OcTreeKey's default constructor leaves its keys uninitialised
  int near_keys = 0;
};

// The keys of one scan, ready to be applied: per-thread brick maps (maps[0] holds the union, with
// occupied winning over free) and its bricks in Morton order.
struct ScanKeys {
  FreeDiscoveryRule free_discovery;  // the scan's, set by FastInserter::insert
  std::vector<BrickMap> maps;
  std::vector<octomap::point3d> discrete_points;
  std::vector<std::uint64_t> sorted;  // (brick Morton code << 24) | brick index, ascending
  std::size_t cells = 0;
  std::size_t memoryUsage() const;
};

// How a voxel of the surface fill is updated (MapperConfig::fill_surfaces_between_returns): `only` where this
// scan's rays did not cross it, `over_free` where they did.
enum class FillMode { none, only, over_free };

// The fill's rule, on the voxel's log-odds before this scan (nullopt: never observed): a hit (true), unless the
// voxel was observed free with confidence — more than twice a miss below even, about three more scans free than
// occupied: an opening beams have looked through — then a miss where this scan's rays crossed it (false), else no
// update (nullopt). Within one scan the fill wins over the rays: a face seen at a grazing angle is crossed by the
// rays to its farther hits in the voxels it cuts through.
inline std::optional<bool> fillUpdate(std::optional<float> log_odds_before, bool crossed_by_scan, float miss_log_odds) {
  if (!log_odds_before || *log_odds_before > 2.5f * miss_log_odds) return true;
  if (crossed_by_scan) return false;
  return std::nullopt;
}

// Stage 1 (rays, de-duplication, occupied-wins, Morton sort). Reads only the tree's key arithmetic
// (resolution and key offset, fixed at construction), never a node, so it may run while stage 2 of
// an earlier scan changes the tree.
// `surface_cells` (may be null): points whose voxels are marked occupied as well, with no ray, by fillUpdate's rule
// (cells a scan's returns imply but no beam hit: MapperConfig::fill_surfaces_between_returns).
// `clear_rays` (may be null): ends of rays cleared up to them, whatever max_range, their end voxel not marked (the
// rays of beams that returned nothing: MapperConfig::clear_beam_gaps); a return's voxel they cross stays a hit.
InsertCounts computeKeys(const octomap::OcTree& tree, const std::vector<octomap::point3d>& points,
                         const octomap::point3d& origin, double max_range, bool discretize, int threads, ScanKeys& keys,
                         const std::vector<octomap::point3d>* surface_cells = nullptr,
                         const std::vector<octomap::point3d>* clear_rays = nullptr);
// Stage 2: applies the keys to the tree; returns the number of threads that walked it. `changed_regions` (may be
// null): the regions (changeRegionOf) where a voxel changed class are appended, some more than once, those where an
// unknown voxel was only observed free tagged kFreeDiscoveryOnly.
int applyKeys(octomap::OcTree& tree, const ScanKeys& keys, int threads,
              std::vector<std::uint64_t>* changed_regions = nullptr);

class FastInserter {
 public:
  FastInserter() = default;
  FastInserter(const FastInserter&) = delete;
  FastInserter& operator=(const FastInserter&) = delete;
  ~FastInserter();

  // points: already finite. max_range < 0 means unlimited (OctoMap's convention).
  // pipelined: the tree update is handed to a background thread and runs while the caller computes the
  // next scan's keys (two key buffers alternate); finish() waits for it. While the walk is the slower stage
  // the scan is walked at once on all `threads` instead (see insert()). The tree after finish() is the
  // same as without pipelining: every scan's update is the same, applied in the same order.
  InsertCounts insert(octomap::OcTree& tree, const std::vector<octomap::point3d>& points,
                      const octomap::point3d& origin, double max_range, bool discretize, int threads,
                      bool pipelined = false, const std::vector<octomap::point3d>* surface_cells = nullptr,
                      const std::vector<octomap::point3d>* clear_rays = nullptr, double free_discovery_near_range = 0.0);
  // Waits until every handed-over tree update is applied; rethrows an exception it raised.
  void finish();
  // The regions (changeRegionOf) where a voxel changed class since the last call, sorted, each once; waits for
  // a pending update first.
  std::vector<std::uint64_t> takeChangedRegions();
  std::size_t memoryUsage() const;
  // Drops the scratch buffers (they are kept between scans to avoid re-allocating them).
  void releaseScratch();

 private:
  void treeThread();
  ScanKeys keys_[2];
  int fill_ = 0;  // the buffer the next scan's keys go to
  // The background tree update (pipelined mode).
  std::thread worker_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  octomap::OcTree* job_tree_ = nullptr;
  const ScanKeys* job_ = nullptr;  // non-null while an update is pending or running
  bool stop_ = false;
  double job_seconds_ = 0.0;
  // Pipelined: the tree walk, not the rays, limited the last scans. True at first: the first scans into an
  // empty tree create most of its nodes, the slowest walks there are.
  bool walk_is_slower_ = true;
  std::exception_ptr job_error_;
  // Appended by whichever thread applies an update (one at a time), read after finish(). Sorted and de-duplicated
  // when it grows past changed_regions_bound_ (boundChangedRegions), so it stays within twice the number of regions
  // the map has.
  void boundChangedRegions();
  std::vector<std::uint64_t> changed_regions_;
  static constexpr std::size_t kMaxChangedRegions = 1 << 16;
  std::size_t changed_regions_bound_ = kMaxChangedRegions;
};

}  // namespace ddsnav::mapper::detail
