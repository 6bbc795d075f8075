#include "ddsnav/perception/obstacle_tracker.hpp"

#include "ddsnav/perception/chi_square.hpp"
#include "ddsnav/perception/euclidean_clusters.hpp"
#include "ddsnav/perception/obstacle_detector.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <string>
#include <stdexcept>
#include <utility>

namespace ddsnav::perception {
namespace {

// A cell of a grid, tagged with the dimension of the tracks that live in it (2-D and 3-D tracks
// never share evidence). dims is 2 or 3 for every stored key; 0 marks an empty slot of CellMap.
struct CellKey {
  std::int32_t x, y, z, dims;
  bool operator==(const CellKey&) const = default;
};

std::uint64_t hashOf(const CellKey& k) {
  std::uint64_t h = static_cast<std::uint32_t>(k.x) * 0x9E3779B97F4A7C15ull;
  h ^= static_cast<std::uint32_t>(k.y) * 0xC2B2AE3D27D4EB4Full;
  h ^= static_cast<std::uint32_t>(k.z) * 0x165667B19E3779F9ull;
  h ^= static_cast<std::uint64_t>(k.dims) << 61;
  h ^= h >> 31;  // mix the high bits down: the slot index takes the low ones
  h *= 0xD6E8FEB86659FD93ull;
  return h ^ (h >> 32);
}

// A flat open-addressing (linear probing) map from cells to small values: one contiguous array,
// no node per entry, no erase (forgetting rebuilds the maps instead). std::unordered_map's node
// lookups were most of the 3-D tracker's time.
template <typename Value>
class CellMap {
 public:
  Value* find(const CellKey& key) {
    if (size_ == 0) return nullptr;
    for (std::size_t i = hashOf(key) & mask_;; i = (i + 1) & mask_) {
      Slot& slot = slots_[i];
      if (slot.key.dims == 0) return nullptr;
      if (slot.key == key) return &slot.value;
    }
  }
  bool contains(const CellKey& key) { return find(key) != nullptr; }
  std::size_t size() const { return size_; }
  void clear() {
    slots_.clear();
    size_ = mask_ = 0;
  }
  // The value stored for key, inserting `value` when key is new (never overwrites, like emplace).
  Value& emplace(const CellKey& key, const Value& value) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    for (std::size_t i = hashOf(key) & mask_;; i = (i + 1) & mask_) {
      Slot& slot = slots_[i];
      if (slot.key == key) return slot.value;
      if (slot.key.dims == 0) {
        slot.key = key;
        slot.value = value;
        ++size_;
        return slot.value;
      }
    }
  }

 private:
  struct Slot {
    CellKey key{0, 0, 0, 0};
    Value value{};
  };
  void grow() {
    std::vector<Slot> old(std::max<std::size_t>(1024, 2 * slots_.size()));
    old.swap(slots_);
    mask_ = slots_.size() - 1;
    for (const Slot& slot : old) {
      if (slot.key.dims == 0) continue;
      std::size_t i = hashOf(slot.key) & mask_;
      while (slots_[i].key.dims != 0) i = (i + 1) & mask_;
      slots_[i] = slot;
    }
  }
  std::vector<Slot> slots_;
  std::size_t size_ = 0, mask_ = 0;
};

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// A sparse grid of cells -> uint32 (kNone = no entry), stored as dense blocks of 4 x 4 x 4 cells
// found through a CellMap of block keys. A voxel's neighbour cells (6 faces, the 27 association
// cells) mostly lie in the block just used, so most lookups hit a cached block instead of probing a
// hash table of a million entries (cache misses on those probes were most of the tracker's time).
class CellGrid {
 public:
  const std::uint32_t* find(const CellKey& cell) {
    const std::uint32_t block = blockOf(cell, false);
    if (block == kNone) return nullptr;
    const std::uint32_t* value = &blockAt(block)[slotOf(cell)];
    return *value == kNone ? nullptr : value;
  }
  // The values of the 3 x 3 x 3 cells around c (3 x 3 in 2-D) in the order dx, dy, dz from -1 to
  // 1 (kNone where absent, or where bit k of `wanted` is clear: those are not looked up); returns
  // how many. At most 8 block lookups instead of 27 cell lookups.
  int neighbourhood(const CellKey& c, std::array<std::uint32_t, 27>& out, std::uint32_t wanted = ~0u) {
    const int dz_lo = c.dims == 3 ? -1 : 0, dz_hi = c.dims == 3 ? 1 : 0;
    const std::int32_t bx0 = (c.x - 1) >> 2, by0 = (c.y - 1) >> 2, bz0 = (c.z + dz_lo) >> 2;
    std::array<const Block*, 8> near{};
    std::array<bool, 8> looked{};
    int n = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = dz_lo; dz <= dz_hi; ++dz) {
          if (!((wanted >> n) & 1u)) {
            out[n++] = kNone;
            continue;
          }
          const CellKey cell{c.x + dx, c.y + dy, c.z + dz, c.dims};
          const int b = ((cell.x >> 2) - bx0) | (((cell.y >> 2) - by0) << 1) | (((cell.z >> 2) - bz0) << 2);
          if (!looked[b]) {
            looked[b] = true;
            const std::uint32_t index = blockOf(cell, false);
            near[b] = index == kNone ? nullptr : &blockAt(index);
          }
          out[n++] = near[b] == nullptr ? kNone : (*near[b])[slotOf(cell)];
        }
    return n;
  }
  // The value stored for cell; `value` is stored first when the cell has none (never overwrites).
  std::uint32_t& emplace(const CellKey& cell, std::uint32_t value) {
    std::uint32_t& stored = blockAt(blockOf(cell, true))[slotOf(cell)];
    if (stored == kNone) stored = value;
    return stored;
  }

 private:
  using Block = std::array<std::uint32_t, 64>;
  struct Cached {
    CellKey key{0, 0, 0, 0};
    std::uint32_t index = kNone;  // kNone: the block does not exist
    bool valid = false;
  };
  static std::size_t slotOf(const CellKey& c) {
    return static_cast<std::size_t>((c.x & 3) | ((c.y & 3) << 2) | ((c.z & 3) << 4));
  }
  // Inlined: ~94 % of lookups hit the cache (city drive), and the call was a good part of their cost.
  [[gnu::always_inline]] std::uint32_t blockOf(const CellKey& c, bool create) {
    const CellKey key{c.x >> 2, c.y >> 2, c.z >> 2, c.dims};  // arithmetic shift: floor(c / 4)
    // The 2 x 2 x 2 blocks around a neighbourhood never share a cache entry.
    Cached& cached = cache_[(key.x & 1) | ((key.y & 1) << 1) | ((key.z & 1) << 2)];
    // Absent blocks are cached too (most lookups around new territory miss); creating a block
    // replaces the entry of its key.
    if (cached.valid && key == cached.key && (cached.index != kNone || !create)) return cached.index;
    return lookUp(key, create, cached);
  }
  [[gnu::noinline]] std::uint32_t lookUp(const CellKey& key, bool create, Cached& cached) {
    std::uint32_t index = kNone;
    if (create) {
      index = index_.emplace(key, static_cast<std::uint32_t>(block_count_));
      if (index == block_count_) {
        if (block_count_ % kChunk == 0) chunks_.push_back(std::make_unique<std::array<Block, kChunk>>());
        blockAt(index).fill(kNone);
        ++block_count_;
      }
    } else if (const std::uint32_t* found = index_.find(key)) {
      index = *found;
    }
    cached = {key, index, true};
    return index;
  }
  // Blocks live in chunks that never move: growing the grid allocates a chunk instead of copying every
  // block (256 bytes each) when a vector would reallocate.
  static constexpr std::size_t kChunk = 1024;  // blocks per chunk (256 KB)
  Block& blockAt(std::uint32_t index) { return (*chunks_[index / kChunk])[index % kChunk]; }
  CellMap<std::uint32_t> index_;  // block key -> block index
  std::vector<std::unique_ptr<std::array<Block, kChunk>>> chunks_;
  std::size_t block_count_ = 0;
  std::array<Cached, 8> cache_{};  // the blocks used last
};

// Cell of p on a grid of edge `size`; false when p is too far out for 32-bit cell indices.
// |floor(q)| < 1e9 exactly when -1e9 + 1 <= q < 1e9 (false for NaN); in that range floor is the
// truncation, one lower for negative non-integers (no libm call: this runs several times per voxel).
bool cellIndex(double q, std::int32_t& index) {
  if (!(q >= -999999999.0 && q < 1e9)) return false;
  const auto t = static_cast<std::int32_t>(q);
  index = static_cast<double>(t) > q ? t - 1 : t;
  return true;
}
[[gnu::always_inline]] inline bool cellOf(const Eigen::Vector3f& p, double size, int dims, CellKey& key) {
  key.dims = dims;
  return cellIndex(static_cast<double>(p.x()) / size, key.x) && cellIndex(static_cast<double>(p.y()) / size, key.y) &&
         cellIndex(static_cast<double>(p.z()) / size, key.z);
}

}  // namespace

struct ObstacleTracker::Evidence {
  struct Track {
    int dims = 2;
    double probability = 0.99;
    // Per voxel: the running mean of the voxel centroids seen in its cell (`position`) and the
    // beam direction of the latest sighting (`bearing`, the range-noise term); stored as the
    // fit's input type, so the refit reads it in place and the output is one memcpy.
    std::vector<SupportPoint> voxels;
    Eigen::Matrix3f frame = Eigen::Matrix3f::Identity();  // the track's own axes, fixed at creation
    Eigen::Vector3f lo = Eigen::Vector3f::Zero(), hi = Eigen::Vector3f::Zero();  // its voxels' box in that frame
    // The ellipse of the last refit, for the check of a refreshed voxel: its centre, the inverse of
    // its covariance (x, y only in 2-D) and chi2(p, d).
    Eigen::Vector3d fit_center = Eigen::Vector3d::Zero();
    Eigen::Matrix3d fit_inverse = Eigen::Matrix3d::Zero();
    double quantile = 0.0;
    bool fitted = false;
    bool structure = false;                // markStructure: part of a hill or wall, not an obstacle
    bool must_refit = false;               // grew, or a refreshed voxel left the ellipse: refit this update
    std::uint64_t stale_since = kNever;    // update of the first refresh not yet in the ellipse
    static constexpr std::uint64_t kNever = std::numeric_limits<std::uint64_t>::max();
  };
  // Every track voxel once more, compactly, for the lookups: its current mean (kept equal to the
  // track's voxel position), how often its cell was seen (capped), which track and voxel it is, and
  // the next node in the same association cell.
  struct Node {
    Eigen::Vector3f mean;
    std::uint32_t hits;
    std::uint32_t track, voxel;  // track kNone: the track was forgotten (skipped until the rebuild)
    std::uint32_t next_nearby;   // kNone ends the association cell's list
  };

  std::vector<Track> tracks;
  std::vector<Node> nodes;
  // Per node: the position it was added at, which chose its cells (a rebuild must use the same ones:
  // the running mean may round across a cell border).
  std::vector<Eigen::Vector3f> added_at;
  std::size_t forgotten_nodes = 0;  // nodes of forgotten tracks still in the lookup structures
  static constexpr std::size_t kMinRebuild = 4096;  // forgotten nodes below this never trigger a rebuild
  std::vector<std::uint32_t> must_refit;                      // tracks to refit at the end of this update
  std::deque<std::pair<std::uint64_t, std::uint32_t>> stale;  // (stale_since, track), oldest first
  std::uint64_t updates = 0;
  double quantile_p = 0.0, quantile = 0.0;  // chi2(quantile_p, quantile_dims), the last one computed
  int quantile_dims = 0;
  CellGrid owner;          // voxel cell -> node of the track voxel there
  CellGrid nearby;         // association cell -> first node of the voxels in it (a list)
  CellMap<bool> coarse;    // kCoarseCell cells holding any track voxel
  static constexpr double kCoarseCell = 1.0;  // m
  // markStructure: the association cells where a scan showed structure (a chain of tracks touching one is
  // structure). Bounded: at kMaxStructureCells the memory starts again (a 110 x 110 m terrain fills ~75 000).
  CellMap<bool> structure_cells;
  static constexpr std::size_t kMaxStructureCells = std::size_t{1} << 20;
  std::vector<std::uint32_t> changed;  // tracks created, grown or refitted in the last update
  // markStructureChains' scratch: the tracks of one chain, a visit stamp per track, the cells scanned.
  std::vector<std::uint32_t> chain;
  std::vector<std::uint32_t> chain_stamp;
  std::uint32_t chain_epoch = 0;
  CellMap<bool> chain_cells;
  EuclideanClusterer clusterer;
  // Scratch buffers of one update, kept across scans.
  std::vector<SupportPoint> pending;
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::pair<float, std::uint32_t>> order;
  std::vector<char> assigned;
  std::vector<std::uint64_t> failed_at;  // events count when the first pass could not place a voxel
  std::vector<std::pair<float, std::uint32_t>> candidates;
  std::vector<std::uint32_t> renumbered;  // forget: old track index -> new one (kNone: forgotten)
  std::vector<Eigen::Vector3f> leftover_points;
  std::vector<SupportPoint> leftovers;
  Clusters groups, pieces;

  explicit Evidence(double association_distance) : clusterer(ClusterParams{association_distance, 1}) {}
};

TrackerParams TrackerParams::matching(const DetectorParams& detector) {
  TrackerParams p;
  p.voxel_size = detector.voxel_size;
  p.association_distance = detector.cluster_tolerance;
  p.voxel_size_3d = std::max(p.voxel_size, std::min(2.0 * p.voxel_size, p.association_distance));
  p.max_segment_length = detector.max_segment_length > 0.0 ? detector.max_segment_length : p.max_segment_length;
  p.max_segment_width = detector.max_segment_width > 0.0 ? detector.max_segment_width : p.max_segment_length;
  p.max_segment_width_3d = detector.max_segment_width_3d > 0.0 ? detector.max_segment_width_3d : p.max_segment_length;
  p.range_noise_sigma = detector.range_noise_sigma;
  p.enclose_points = detector.enclose_points;
  // No voxel of a scan lies beyond max_range, so none can reach a track beyond this (see the header).
  p.forget_radius = detector.max_range + 4.0 * detector.cluster_tolerance;
  return p;
}

void TrackerParams::validate() const {
  auto require = [](bool ok, const char* name, const char* expected) {
    if (!ok) throw std::invalid_argument(std::string("tracker parameter '") + name + "' must be " + expected);
  };
  require(std::isfinite(voxel_size) && voxel_size >= 0.001 && voxel_size <= 100.0, "voxel_size", "in [0.001, 100] m");
  require(std::isfinite(voxel_size_3d) && voxel_size_3d >= 0.001 && voxel_size_3d <= 100.0, "voxel_size_3d",
          "in [0.001, 100] m");
  require(std::isfinite(association_distance) && association_distance >= std::max(voxel_size, voxel_size_3d) &&
              association_distance <= 100.0,
          "association_distance", "in [max(voxel_size, voxel_size_3d), 100] m");
  require(std::isfinite(max_segment_length) && max_segment_length >= association_distance,
          "max_segment_length", "finite and >= association_distance");
  require(std::isfinite(max_segment_width) && max_segment_width > 0.0 && max_segment_width <= max_segment_length,
          "max_segment_width", "in (0, max_segment_length]");
  require(std::isfinite(max_segment_width_3d) && max_segment_width_3d > 0.0 && max_segment_width_3d <= max_segment_length,
          "max_segment_width_3d", "in (0, max_segment_length]");
  require(std::isfinite(range_noise_sigma) && range_noise_sigma >= 0.0, "range_noise_sigma", "finite and >= 0");
  require(max_voxels_per_track >= 1, "max_voxels_per_track", ">= 1");
  require(max_deferred_refits >= 1, "max_deferred_refits", ">= 1");
  require(forget_radius > 0.0, "forget_radius", "> 0 m (infinity: never forget)");
}

ObstacleTracker::ObstacleTracker(const TrackerParams& params) : params_(params) {
  params_.validate();
  evidence_ = std::make_unique<Evidence>(params_.association_distance);
}
ObstacleTracker::~ObstacleTracker() = default;
ObstacleTracker::ObstacleTracker(ObstacleTracker&&) noexcept = default;
ObstacleTracker& ObstacleTracker::operator=(ObstacleTracker&&) noexcept = default;

const std::vector<ObstacleEllipsoid>& ObstacleTracker::update(std::span<const ObstacleEllipsoid> detections,
                                                             const Eigen::Vector3d& sensor_origin) {
  last_ = {};
  forget(sensor_origin);
  return associate(detections);
}

const std::vector<ObstacleEllipsoid>& ObstacleTracker::update(std::span<const ObstacleEllipsoid> detections) {
  last_ = {};
  return associate(detections);
}

namespace {
// True when every voxel of a track lies farther than radius from `origin`. The track's box (in its own
// frame, holding every voxel) decides most tracks; only those near the sphere are checked voxel by voxel,
// with the same arithmetic as the reference.
bool entirelyFarther(std::span<const SupportPoint> voxels, const Eigen::Matrix3f& frame, const Eigen::Vector3f& lo,
                     const Eigen::Vector3f& hi, const Eigen::Vector3d& origin, double radius) {
  const double centre = ((frame * (0.5f * (lo + hi))).cast<double>() - origin).norm();
  const double half_diagonal = 0.5 * static_cast<double>((hi - lo).norm());
  // float rounding of the box and frame: generous against positions' 24-bit mantissas
  const double slack = 1e-3 + 1e-5 * (centre + origin.norm() + half_diagonal);
  if (centre - half_diagonal > radius + slack) return true;
  if (centre + half_diagonal < radius - slack) return false;
  const double radius2 = radius * radius;
  for (const SupportPoint& v : voxels)
    if ((v.position.cast<double>() - origin).squaredNorm() <= radius2) return false;
  return true;
}
}  // namespace

void ObstacleTracker::forget(const Eigen::Vector3d& sensor_origin) {
  auto& ev = *evidence_;
  const double radius = params_.forget_radius;
  if (!(radius < std::numeric_limits<double>::infinity()) || ev.tracks.empty()) return;
  auto& renumbered = ev.renumbered;
  renumbered.resize(ev.tracks.size());
  std::uint32_t kept = 0;
  std::size_t forgotten_voxels = 0;
  for (std::size_t t = 0; t < ev.tracks.size(); ++t) {
    const auto& track = ev.tracks[t];
    Eigen::Vector3d origin = sensor_origin;
    if (track.dims == 2) origin.z() = 0.0;
    if (entirelyFarther(track.voxels, track.frame, track.lo, track.hi, origin, radius)) {
      renumbered[t] = kNone;
      forgotten_voxels += track.voxels.size();
    } else {
      renumbered[t] = kept++;
    }
  }
  if (kept == ev.tracks.size()) return;
  last_.forgotten = ev.tracks.size() - kept;
  // Keep the creation order (ids ascending, and the tie order of association candidates).
  for (std::size_t t = 0; t < ev.tracks.size(); ++t) {
    const std::uint32_t to = renumbered[t];
    if (to == kNone || to == t) continue;
    ev.tracks[to] = std::move(ev.tracks[t]);
    tracks_[to] = std::move(tracks_[t]);
  }
  ev.tracks.erase(ev.tracks.begin() + kept, ev.tracks.end());
  tracks_.erase(tracks_.begin() + kept, tracks_.end());
  for (auto& node : ev.nodes)
    if (node.track != kNone) node.track = renumbered[node.track];
  std::deque<std::pair<std::uint64_t, std::uint32_t>> stale;
  for (const auto& [since, t] : ev.stale)
    if (renumbered[t] != kNone) stale.emplace_back(since, renumbered[t]);
  ev.stale.swap(stale);
  ev.forgotten_nodes += forgotten_voxels;
  if (ev.forgotten_nodes < Evidence::kMinRebuild || ev.forgotten_nodes <= ev.nodes.size() - ev.forgotten_nodes) return;

  // Rebuild the lookup structures from the live nodes, each in the cells it was added to.
  std::vector<Evidence::Node> nodes;
  std::vector<Eigen::Vector3f> added_at;
  nodes.reserve(ev.nodes.size() - ev.forgotten_nodes);
  added_at.reserve(nodes.capacity());
  CellGrid owner, nearby;
  CellMap<bool> coarse;
  const double tol = params_.association_distance;
  for (std::size_t n = 0; n < ev.nodes.size(); ++n) {
    Evidence::Node node = ev.nodes[n];
    if (node.track == kNone) continue;
    const auto index = static_cast<std::uint32_t>(nodes.size());
    const Eigen::Vector3f& at = ev.added_at[n];
    const int dims = ev.tracks[node.track].dims;
    node.next_nearby = kNone;
    CellKey key;
    if (cellOf(at, params_.voxelSize(dims), dims, key)) owner.emplace(key, index);
    if (cellOf(at, tol, dims, key)) {
      std::uint32_t& head = nearby.emplace(key, index);
      if (head != index) {
        node.next_nearby = head;
        head = index;
      }
    }
    if (cellOf(at, Evidence::kCoarseCell, dims, key)) coarse.emplace(key, true);
    nodes.push_back(node);
    added_at.push_back(at);
  }
  ev.nodes.swap(nodes);
  ev.added_at.swap(added_at);
  ev.owner = std::move(owner);
  ev.nearby = std::move(nearby);
  ev.coarse = std::move(coarse);
  ev.forgotten_nodes = 0;
}

const std::vector<ObstacleEllipsoid>& ObstacleTracker::associate(std::span<const ObstacleEllipsoid> detections) {
  auto& ev = *evidence_;
  ++ev.updates;
  for (const auto& detection : detections) absorb(detection);

  // Refit the tracks whose evidence grew or left their ellipse (only those: the list, not a scan
  // over every track), then the deferred refresh-only ones that are due, oldest first.
  ev.changed.assign(ev.must_refit.begin(), ev.must_refit.end());
  for (std::uint32_t t : ev.must_refit) refit(t);
  ev.must_refit.clear();
  std::size_t budget = params_.max_deferred_refits;
  while (!ev.stale.empty()) {
    const auto [since, t] = ev.stale.front();
    if (ev.tracks[t].stale_since != since) {  // refitted since it was queued
      ev.stale.pop_front();
      continue;
    }
    if (ev.updates - since < params_.max_refit_delay || budget == 0) break;
    ev.stale.pop_front();
    refit(t);
    ++last_.refitted_late;
    --budget;
  }
  for (const auto& [since, t] : ev.stale) last_.deferred += ev.tracks[t].stale_since == since;
  return tracks_;
}

const std::vector<ObstacleEllipsoid>& ObstacleTracker::refitDeferred() {
  auto& ev = *evidence_;
  for (const auto& [since, t] : ev.stale)
    if (ev.tracks[t].stale_since == since) refit(t);
  ev.stale.clear();
  last_.deferred = 0;
  return tracks_;
}

std::size_t ObstacleTracker::markStructure(std::span<const Eigen::Vector3f> voxels, int dims) {
  auto& ev = *evidence_;
  if (dims != 2 && dims != 3) return 0;
  const double tol = params_.association_distance;
  std::size_t marked = 0;
  // One visit per association cell of the structure (a surface scan puts dozens of voxels in each); the
  // tracks listed in it and its neighbours (within ~1-2 association distances: a sparse far-range glimpse of
  // the same surface rarely lands in the very voxel cells a later scan hits) become structure. Every cell is
  // remembered for markStructureChains.
  CellMap<bool> visited;
  std::array<std::uint32_t, 27> heads;
  for (Eigen::Vector3f v : voxels) {
    if (dims == 2) v.z() = 0.0f;
    CellKey coarse, cell;
    if (!cellOf(v, tol, dims, cell) || visited.contains(cell)) continue;
    visited.emplace(cell, true);
    if (ev.structure_cells.size() >= Evidence::kMaxStructureCells) ev.structure_cells.clear();
    ev.structure_cells.emplace(cell, true);
    // Most structure lies where no track is: one probe of the coarse grid skips it.
    if (!cellOf(v, Evidence::kCoarseCell, dims, coarse) || !ev.coarse.contains(coarse)) continue;
    const int n = ev.nearby.neighbourhood(cell, heads);
    for (int k = 0; k < n; ++k)
      for (std::uint32_t node = heads[k]; node != kNone; node = ev.nodes[node].next_nearby) {
        if (ev.nodes[node].track == kNone) continue;  // forgotten
        auto& track = ev.tracks[ev.nodes[node].track];
        if (track.structure) continue;
        track.structure = true;
        ++marked;
      }
  }
  return marked;
}

std::size_t ObstacleTracker::markStructureChains(double extent) {
  auto& ev = *evidence_;
  if (!(extent > 0.0) || ev.changed.empty()) return 0;
  const double tol = params_.association_distance;
  const float limit2 = static_cast<float>(extent * extent);
  ev.chain_stamp.resize(ev.tracks.size(), 0);
  if (++ev.chain_epoch == 0) {  // wrapped: every old stamp could look current
    std::fill(ev.chain_stamp.begin(), ev.chain_stamp.end(), 0);
    ev.chain_epoch = 1;
  }
  const std::uint32_t epoch = ev.chain_epoch;
  ev.chain_cells.clear();
  std::array<std::uint32_t, 27> heads;
  std::size_t marked = 0;
  for (const std::uint32_t start : ev.changed) {
    if (start >= ev.tracks.size() || ev.tracks[start].structure || ev.chain_stamp[start] == epoch) continue;
    // Breadth first over the tracks whose voxels lie in or next to each other's association cells (the
    // clustering's connectivity, as markStructure's neighbourhood), never through a structure track.
    ev.chain.assign(1, start);
    ev.chain_stamp[start] = epoch;
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
    bool structure = false;
    for (std::size_t k = 0; k < ev.chain.size(); ++k) {
      const auto& track = ev.tracks[ev.chain[k]];
      const int dims = track.dims;
      for (const SupportPoint& voxel : track.voxels) {
        Eigen::Vector3f p = voxel.position;
        if (dims == 2) p.z() = 0.0f;
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
        CellKey cell;
        if (!cellOf(p, tol, dims, cell) || ev.chain_cells.contains(cell)) continue;
        ev.chain_cells.emplace(cell, true);
        const int n = ev.nearby.neighbourhood(cell, heads);
        for (int j = 0; j < n; ++j)
          for (std::uint32_t node = heads[j]; node != kNone; node = ev.nodes[node].next_nearby) {
            const std::uint32_t t = ev.nodes[node].track;
            if (t == kNone || ev.chain_stamp[t] == epoch) continue;
            if (ev.tracks[t].structure) {
              structure = true;  // touches a track already known as structure
              continue;
            }
            ev.chain_stamp[t] = epoch;
            ev.chain.push_back(t);
          }
        if (!structure && ev.structure_cells.size() > 0) {
          for (int dx = -1; dx <= 1 && !structure; ++dx)
            for (int dy = -1; dy <= 1 && !structure; ++dy)
              for (int dz = dims == 3 ? -1 : 0; dz <= (dims == 3 ? 1 : 0) && !structure; ++dz)
                structure = ev.structure_cells.contains(CellKey{cell.x + dx, cell.y + dy, cell.z + dz, dims});
        }
      }
    }
    if (!structure && (hi - lo).squaredNorm() <= limit2) continue;
    for (const std::uint32_t t : ev.chain) {
      ev.tracks[t].structure = true;
      ++marked;
    }
  }
  return marked;
}

bool ObstacleTracker::isStructure(std::size_t index) const { return evidence_->tracks.at(index).structure; }

std::vector<std::size_t> ObstacleTracker::discreteObstacles(const Eigen::Vector3d& from, std::size_t max_count) const {
  std::vector<std::size_t> out;
  const auto& tracks = evidence_->tracks;
  for (std::size_t i = 0; i < tracks.size(); ++i)
    if (!tracks[i].structure) out.push_back(i);
  if (out.size() <= max_count) return out;
  auto distance2 = [&](std::size_t i) {
    Eigen::Vector3d d = tracks_[i].center - from;
    if (tracks_[i].dimensions == 2) d.z() = 0.0;
    return d.squaredNorm();
  };
  std::nth_element(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(max_count), out.end(),
                   [&](std::size_t a, std::size_t b) { return distance2(a) < distance2(b) || (distance2(a) == distance2(b) && a < b); });
  out.resize(max_count);
  std::sort(out.begin(), out.end());
  return out;
}

std::span<const SupportPoint> ObstacleTracker::evidence(std::size_t index) const {
  return evidence_->tracks.at(index).voxels;
}

// Refits one track with the detector's model and keeps what the refresh check needs.
void ObstacleTracker::refit(std::size_t t) {
  auto& track = evidence_->tracks[t];
  track.must_refit = false;
  track.stale_since = Evidence::Track::kNever;
  std::vector<SupportPoint> support = std::move(tracks_[t].support);  // reuse its capacity
  support.assign(track.voxels.begin(), track.voxels.end());
  const EllipsoidFitParams fit{track.probability, params_.range_noise_sigma, params_.voxelSize(track.dims),
                               params_.enclose_points};
  ObstacleEllipsoid estimate = fitEllipsoid(track.voxels, track.dims, fit);
  estimate.id = tracks_[t].id;
  estimate.support = std::move(support);
  track.fit_center = estimate.center;
  track.fit_inverse.setZero();
  if (track.dims == 2) {
    track.fit_inverse.topLeftCorner<2, 2>() = estimate.covariance.topLeftCorner<2, 2>().inverse();
  } else {
    track.fit_inverse = estimate.covariance.inverse();
  }
  track.fitted = track.fit_inverse.allFinite();
  tracks_[t] = std::move(estimate);
  ++last_.refitted;
}

void ObstacleTracker::absorb(const ObstacleEllipsoid& detection) {
  auto& ev = *evidence_;
  const int dims = detection.dimensions;
  if ((dims != 2 && dims != 3) || detection.support.empty() || !(detection.probability > 0.0) ||
      !(detection.probability < 1.0)) {
    ++last_.ignored;
    return;
  }
  ev.pending.clear();
  for (SupportPoint s : detection.support) {
    if (dims == 2) s.position.z() = s.bearing.z() = 0.0f;
    if (s.position.allFinite() && s.bearing.allFinite()) ev.pending.push_back(s);
  }
  if (ev.pending.empty()) {
    ++last_.ignored;
    return;
  }
  // Walk the detection along its length, so a track grows voxel by voxel from the end it touches.
  auto& positions = ev.positions;
  positions.clear();
  for (const auto& s : ev.pending) positions.push_back(s.position);
  const Eigen::Vector3f axis = principalAxes(positions, {}, dims).col(0);
  auto& order = ev.order;
  order.clear();
  for (std::uint32_t i = 0; i < ev.pending.size(); ++i) order.emplace_back(axis.dot(positions[i]), i);
  std::sort(order.begin(), order.end());

  const double tol = params_.association_distance;
  const float tol2 = static_cast<float>(tol * tol);
  const float max_length = static_cast<float>(params_.max_segment_length);
  const float max_width = static_cast<float>(params_.segmentWidth(dims));
  std::size_t refreshed = 0, added = 0;
  // How far a voxel's mean may lie outside the association cell it is listed in: rounding only when
  // association cells are whole multiples of voxel cells (the defaults: 0.4 = 4 x 0.1), else up to a
  // voxel (a voxel cell then straddles association cells).
  const double voxel = params_.voxelSize(dims);
  const double cells_per_cell = tol / voxel;
  const double cell_drift =
      std::abs(cells_per_cell - std::round(cells_per_cell)) < 1e-9 ? 1e-4 : 1.0001 * voxel;

  auto mustRefit = [&](std::uint32_t t) {
    auto& track = ev.tracks[t];
    if (track.must_refit) return;
    track.must_refit = true;
    ev.must_refit.push_back(t);
  };
  // A voxel was added to track t or refreshed (moved within its cell). The track keeps the ellipse
  // of its last refit for up to max_refit_delay updates as long as the voxel, pushed outward by its
  // position uncertainty (the fit's margin), is inside it; otherwise it is refitted in this update.
  const bool may_defer = params_.max_refit_delay > 0 && params_.enclose_points;
  const double margin = enclosingMargin(params_.range_noise_sigma, voxel, dims);
  auto changedVoxel = [&](std::uint32_t t, const Eigen::Vector3f& position) {
    auto& track = ev.tracks[t];
    if (track.must_refit) return;
    if (!may_defer || !track.fitted) return mustRefit(t);
    Eigen::Vector3d d = position.cast<double>() - track.fit_center;
    if (dims == 2) d.z() = 0.0;
    const double length = d.norm();
    if (length > 0.0) d *= (length + margin) / length;
    if (!(d.dot(track.fit_inverse * d) <= track.quantile)) return mustRefit(t);
    if (track.stale_since == Evidence::Track::kNever) {
      track.stale_since = ev.updates;
      ev.stale.emplace_back(ev.updates, t);
    }
  };

  // The last voxel the walk assigned (its track and position): along a surface, the next voxel is
  // usually within the association distance of it, which needs no hash lookup at all.
  std::uint32_t previous_track = 0;
  Eigen::Vector3f previous_position = Eigen::Vector3f::Zero();
  bool has_previous = false;
  // Refreshes and additions so far: a voxel the first pass could not place, with no event since,
  // would fail the second pass the same way (same evidence, and no previous voxel yet), so it is
  // skipped there.
  std::uint64_t events = 0;
  CellKey last_coarse{0, 0, 0, 0};  // the coarse cell addVoxel marked last (dims 0: none yet)
  auto addVoxel = [&](std::uint32_t t, const SupportPoint& s, const CellKey& key) {
    ++events;
    previous_track = t;
    auto& track = ev.tracks[t];
    const auto index = static_cast<std::uint32_t>(track.voxels.size());
    const auto node = static_cast<std::uint32_t>(ev.nodes.size());
    track.voxels.push_back({s.position, s.bearing});
    changedVoxel(t, s.position);
    ev.nodes.push_back({s.position, 1, t, index, kNone});
    ev.added_at.push_back(s.position);
    ev.owner.emplace(key, node) = node;  // a live owner would have refreshed; a forgotten one gives way
    CellKey near_key;
    if (cellOf(s.position, tol, dims, near_key)) {
      // Prepend to the cell's list (the candidate order does not matter: candidates are sorted).
      std::uint32_t& head = ev.nearby.emplace(near_key, node);
      if (head != node) {
        ev.nodes[node].next_nearby = head;
        head = node;
      }
    }
    // Consecutive voxels mostly share their coarse cell: probe the map only when it changes.
    if (cellOf(s.position, Evidence::kCoarseCell, dims, near_key) && !(near_key == last_coarse)) {
      ev.coarse.emplace(near_key, true);
      last_coarse = near_key;
    }
  };
  // A voxel in a cell a track owns refreshes it (the centroid averages the noise out over scans).
  auto refresh = [&](const SupportPoint& s, const CellKey& key) {
    const std::uint32_t* owned = ev.owner.find(key);
    if (owned == nullptr || ev.nodes[*owned].track == kNone) return false;
    ++events;
    Evidence::Node& node = ev.nodes[*owned];
    previous_track = node.track;
    auto& track = ev.tracks[node.track];
    SupportPoint& v = track.voxels[node.voxel];
    node.hits = std::min<std::uint32_t>(node.hits + 1, 1000);
    node.mean += (s.position - node.mean) / static_cast<float>(node.hits);
    v.position = node.mean;
    v.bearing = s.bearing;
    const Eigen::Vector3f q = track.frame.transpose() * node.mean;  // stays within its cell
    track.lo = track.lo.cwiseMin(q);
    track.hi = track.hi.cwiseMax(q);
    changedVoxel(node.track, node.mean);
    return true;
  };
  // A voxel in a new cell joins the nearest track with a voxel within the association distance
  // whose box can take it; false when there is none.
  auto accepts = [&](std::uint32_t t, const SupportPoint& s) {
    auto& track = ev.tracks[t];
    if (track.voxels.size() >= params_.max_voxels_per_track) return false;
    const Eigen::Vector3f q = track.frame.transpose() * s.position;
    const Eigen::Vector3f lo = track.lo.cwiseMin(q), hi = track.hi.cwiseMax(q);
    if (pieceTooBig(hi - lo, dims, max_length, max_width)) return false;  // that track is full this way
    track.lo = lo;
    track.hi = hi;
    return true;
  };
  // The track of the voxel the walk assigned last, when it is within the distance: no hash lookup.
  // 3-D tries it first (measured: 26 instead of 35 ms per city-block scan, as most new cells of a
  // sparsely sampled surface have no owned face neighbour); 2-D tries it after the face neighbours
  // (fewer fragments: 117 instead of 133 tracks on the demo drive).
  auto joinPrevious = [&](const SupportPoint& s, const CellKey& key) {
    if (!has_previous || (previous_position - s.position).squaredNorm() >= tol2 || !accepts(previous_track, s))
      return false;
    addVoxel(previous_track, s, key);
    return true;
  };
  auto extend = [&](const SupportPoint& s, const CellKey& key) {
    if (dims == 3 && joinPrevious(s, key)) return true;
    // A face-adjacent voxel cell owned by a track (a surface growing by one voxel, or
    // noise moving a centroid into the next cell) — the nearest track in all but ties.
    for (int axis = 0; axis < dims; ++axis)
      for (int step : {-1, 1}) {
        CellKey adjacent = key;
        (axis == 0 ? adjacent.x : axis == 1 ? adjacent.y : adjacent.z) += step;
        const std::uint32_t* owned = ev.owner.find(adjacent);
        if (owned == nullptr) continue;
        const Evidence::Node& v = ev.nodes[*owned];
        if (v.track == kNone) continue;
        if ((v.mean - s.position).squaredNorm() >= tol2) continue;
        if (accepts(v.track, s)) {
          addVoxel(v.track, s, key);
          return true;
        }
      }
    if (dims == 2 && joinPrevious(s, key)) return true;
    CellKey c;
    if (!cellOf(s.position, tol, dims, c)) return false;
    ev.candidates.clear();
    // A neighbour cell whose box is at least the association distance away cannot hold a voxel within
    // it (a voxel's mean stays inside the voxel cell it was added in, so inside this box up to
    // cell_drift): it is neither looked up nor walked. Only cells that could hold a candidate are
    // visited, so the candidates are the same. About a quarter of the 27 cells of a 3-D neighbourhood
    // are skipped.
    const double p[3] = {s.position.x(), s.position.y(), s.position.z()};
    const std::int32_t ci[3] = {c.x, c.y, c.z};
    double below[3], above[3];
    for (int a = 0; a < 3; ++a) {
      below[a] = std::max(0.0, p[a] - static_cast<double>(ci[a]) * tol - cell_drift);
      above[a] = std::max(0.0, static_cast<double>(ci[a] + 1) * tol - p[a] - cell_drift);
    }
    const int dz_lo = dims == 3 ? -1 : 0, dz_hi = dims == 3 ? 1 : 0;
    std::uint32_t wanted = 0;
    int k = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = dz_lo; dz <= dz_hi; ++dz, ++k) {
          const double gx = dx < 0 ? below[0] : dx > 0 ? above[0] : 0.0;
          const double gy = dy < 0 ? below[1] : dy > 0 ? above[1] : 0.0;
          const double gz = dz < 0 ? below[2] : dz > 0 ? above[2] : 0.0;
          if (gx * gx + gy * gy + gz * gz < tol * tol) wanted |= 1u << k;
        }
    std::array<std::uint32_t, 27> heads;
    const int cells = ev.nearby.neighbourhood(c, heads, wanted);
    for (k = 0; k < cells; ++k) {
      const std::uint32_t head = heads[k];
      if (head == kNone) continue;
      for (std::uint32_t n = head; n != kNone; n = ev.nodes[n].next_nearby) {
        const Evidence::Node& ref = ev.nodes[n];
        const float d2 = (ref.mean - s.position).squaredNorm();
        if (d2 >= tol2 || ref.track == kNone) continue;
        auto found = std::find_if(ev.candidates.begin(), ev.candidates.end(),
                                  [&](const auto& cand) { return cand.second == ref.track; });
        if (found == ev.candidates.end()) {
          ev.candidates.emplace_back(d2, ref.track);
        } else {
          found->first = std::min(found->first, d2);
        }
      }
    }
    std::sort(ev.candidates.begin(), ev.candidates.end());
    for (const auto& [d2, t] : ev.candidates) {
      if (!accepts(t, s)) continue;
      addVoxel(t, s, key);
      return true;
    }
    return false;
  };

  // A detection in new territory (no track voxel within the association distance of its box)
  // starts tracks without the per-voxel search: a few coarse-cell lookups instead of 28 per voxel.
  bool near_any_track = false;
  {
    Eigen::Vector3f lo = positions[0], hi = positions[0];
    for (const auto& p : positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    CellKey a, b;
    const Eigen::Vector3f grow = Eigen::Vector3f::Constant(static_cast<float>(tol));
    if (cellOf(lo - grow, Evidence::kCoarseCell, dims, a) && cellOf(hi + grow, Evidence::kCoarseCell, dims, b)) {
      for (int x = a.x; x <= b.x && !near_any_track; ++x)
        for (int y = a.y; y <= b.y && !near_any_track; ++y)
          for (int z = a.z; z <= b.z && !near_any_track; ++z) near_any_track = ev.coarse.contains({x, y, z, dims});
    } else {
      near_any_track = true;  // too far out for cell indices: take the careful path
    }
  }
  auto& assigned = ev.assigned;
  assigned.assign(ev.pending.size(), 0);
  auto& failed_at = ev.failed_at;
  failed_at.resize(ev.pending.size());
  auto pass = [&](auto first, auto last, bool second) {
    for (auto it = first; it != last; ++it) {
      const std::uint32_t i = it->second;
      if (assigned[i] || (second && failed_at[i] == events)) continue;
      CellKey key;
      if (!cellOf(ev.pending[i].position, params_.voxelSize(dims), dims, key)) {
        assigned[i] = 1;  // too far out to store; dropped
        continue;
      }
      if (refresh(ev.pending[i], key)) {
        assigned[i] = 1;
        ++refreshed;
      } else if (extend(ev.pending[i], key)) {
        assigned[i] = 1;
        ++added;
      } else {
        failed_at[i] = events;
        continue;
      }
      has_previous = true;  // previous_track was set by refresh / addVoxel
      previous_position = ev.pending[i].position;
    }
    has_previous = false;
  };
  if (near_any_track) {
    pass(order.begin(), order.end(), false);
    pass(order.rbegin(), order.rend(), true);
  }

  // What no track could take: connected groups, cut to the segment length, each a new track.
  ev.leftovers.clear();
  ev.leftover_points.clear();
  for (std::size_t i = 0; i < ev.pending.size(); ++i)
    if (!assigned[i]) {
      ev.leftovers.push_back(ev.pending[i]);
      ev.leftover_points.push_back(ev.pending[i].position);
    }
  if (!ev.leftovers.empty()) {
    ev.clusterer.extract(ev.leftover_points, ev.groups);
    ev.pieces.clear();
    for (std::size_t g = 0; g < ev.groups.size(); ++g)
      splitByExtent(ev.leftover_points, ev.groups[g], dims, params_.max_segment_length,
                    params_.segmentWidth(dims), ev.pieces);
    for (std::size_t k = 0; k < ev.pieces.size(); ++k) {
      const auto piece = ev.pieces[k];
      Evidence::Track track;
      track.dims = dims;
      track.probability = detection.probability;
      if (ev.quantile_p != detection.probability || ev.quantile_dims != dims) {  // one value in practice
        ev.quantile_p = detection.probability;
        ev.quantile_dims = dims;
        ev.quantile = chiSquareQuantile(detection.probability, dims);
      }
      track.quantile = ev.quantile;
      track.frame = principalAxes(ev.leftover_points, piece, dims);
      track.lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
      track.hi = -track.lo;
      for (int i : piece) {
        const Eigen::Vector3f q = track.frame.transpose() * ev.leftover_points[static_cast<std::size_t>(i)];
        track.lo = track.lo.cwiseMin(q);
        track.hi = track.hi.cwiseMax(q);
      }
      const auto t = static_cast<std::uint32_t>(ev.tracks.size());
      ev.tracks.push_back(std::move(track));
      ObstacleEllipsoid placeholder;
      placeholder.id = next_id_++;
      placeholder.dimensions = dims;
      tracks_.push_back(std::move(placeholder));
      for (int i : piece) {
        const SupportPoint& s = ev.leftovers[static_cast<std::size_t>(i)];
        CellKey key;
        if (!cellOf(s.position, params_.voxelSize(dims), dims, key)) continue;
        if (!refresh(s, key)) addVoxel(t, s, key);
      }
      if (ev.tracks[t].voxels.empty()) {  // every voxel refreshed another new track: nothing to keep
        ev.tracks.pop_back();
        tracks_.pop_back();
        --next_id_;
        continue;
      }
      ++last_.created;
    }
  }
  last_.refreshed_voxels += refreshed;
  last_.added_voxels += added;
  if (refreshed + added > 0) ++last_.fused;
}

}  // namespace ddsnav::perception
