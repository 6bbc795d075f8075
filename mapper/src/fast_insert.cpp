#include "fast_insert.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <thread>

namespace ddsnav::mapper::detail {
namespace {

constexpr std::uint64_t kEmpty = ~0ull;
constexpr unsigned kTreeDepth = 16;  // OcTree keys are 16 bits per axis

// Bit position of a 3-bit coordinate inside a 9-bit Morton index (x at bit 0, y at 1, z at 2, as OctoMap
// numbers a node's children: computeChildIdx).
constexpr std::array<std::uint32_t, 8> kSpread3 = {0, 1, 8, 9, 64, 65, 72, 73};

std::uint32_t localIndex(const octomap::OcTreeKey& k) {
  return kSpread3[k[0] & 7] | (kSpread3[k[1] & 7] << 1) | (kSpread3[k[2] & 7] << 2);
}

// Spreads the low 13 bits of v to every third bit.
std::uint64_t spread13(std::uint64_t v) {
  std::uint64_t r = 0;
  for (unsigned i = 0; i < 13; ++i) r |= ((v >> i) & 1ull) << (3 * i);
  return r;
}

std::uint64_t packBrick(const octomap::OcTreeKey& k) {
  return std::uint64_t(k[0] >> 3) | (std::uint64_t(k[1] >> 3) << 13) | (std::uint64_t(k[2] >> 3) << 26);
}

std::uint64_t brickMorton(std::uint64_t packed) {
  return spread13(packed & 0x1fff) | (spread13((packed >> 13) & 0x1fff) << 1) | (spread13(packed >> 26) << 2);
}

std::size_t slotOf(std::uint64_t packed, std::size_t mask) {
  return static_cast<std::size_t>((packed * 0x9E3779B97F4A7C15ull) >> 20) & mask;
}

// Key of the voxel at Morton code m (48 bits: brick Morton << 9 | local index).
octomap::OcTreeKey keyOfMorton(std::uint64_t m) {
  octomap::OcTreeKey k(0, 0, 0);
  for (unsigned i = 0; i < kTreeDepth; ++i) {
    k[0] |= static_cast<octomap::key_type>(((m >> (3 * i)) & 1u) << i);
    k[1] |= static_cast<octomap::key_type>(((m >> (3 * i + 1)) & 1u) << i);
    k[2] |= static_cast<octomap::key_type>(((m >> (3 * i + 2)) & 1u) << i);
  }
  return k;
}

unsigned childIndex(const octomap::OcTreeKey& k, unsigned level) {
  return ((k[0] >> level) & 1u) | (((k[1] >> level) & 1u) << 1) | (((k[2] >> level) & 1u) << 2);
}

// OcTreeBaseImpl keeps the root pointer protected and has no public way to create it; a pointer to member
// formed inside a derived class reaches it without changing the tree's type (it stays a plain OcTree, so
// writeBinary and every OctoMap tool see the usual "OcTree").
struct TreeAccess : octomap::OcTree {
  static octomap::OcTreeNode*& rootOf(octomap::OcTree& t) { return t.*(&TreeAccess::root); }
  static std::size_t& sizeOf(octomap::OcTree& t) { return t.*(&TreeAccess::tree_size); }
  static bool& sizeChangedOf(octomap::OcTree& t) { return t.*(&TreeAccess::size_changed); }
};

// The walk over Morton-ordered voxels described in fast_insert.hpp.
class TreeWalk {
 public:
  explicit TreeWalk(octomap::OcTree& tree)
      : tree_(tree),
        hit_(tree.getProbHitLog()),
        miss_(tree.getProbMissLog()),
        clamp_min_(tree.getClampingThresMinLog()),
        clamp_max_(tree.getClampingThresMaxLog()) {
    octomap::OcTreeNode*& root = TreeAccess::rootOf(tree_);
    if (root == nullptr) {
      root = new octomap::OcTreeNode();
      ++TreeAccess::sizeOf(tree_);
      TreeAccess::sizeChangedOf(tree_) = true;
      fresh_[0] = true;
    }
    path_[0] = root;
    valid_ = 0;
  }

  void update(std::uint64_t morton, bool occupied) {
    const octomap::OcTreeKey key = keyOfMorton(morton);
    int keep = 0;
    if (has_previous_) {
      const unsigned level = (63u - static_cast<unsigned>(std::countl_zero(morton ^ previous_))) / 3u;
      keep = static_cast<int>(kTreeDepth - 1 - level);  // depth of the deepest shared ancestor
    }
    previous_ = morton;
    has_previous_ = true;
    keep = std::min(keep, valid_);
    finishDownTo(keep);

    const float delta = occupied ? hit_ : miss_;
    int d = keep;
    octomap::OcTreeNode* node = path_[d];
    while (d < static_cast<int>(kTreeDepth)) {
      const unsigned pos = childIndex(key, kTreeDepth - 1 - d);
      bool created = false;
      if (!tree_.nodeChildExists(node, pos)) {
        if (!tree_.nodeHasChildren(node) && !fresh_[d]) {
          // A pruned leaf: OctoMap's updateNode() finds it with search() and stops early when the
          // update cannot change it.
          if (atClamp(node, delta)) {
            valid_ = d;
            return;
          }
          tree_.expandNode(node);
        } else {
          tree_.createNodeChild(node, pos);
          created = true;
        }
      }
      node = tree_.getNodeChild(node, pos);
      ++d;
      path_[d] = node;
      fresh_[d] = created;
    }
    valid_ = d;
    if (!fresh_[d] && atClamp(node, delta)) return;
    tree_.updateNodeLogOdds(node, delta);
  }

  // Finishes every node still on the path (call once after the last update).
  void finish() {
    finishDownTo(-1);
    valid_ = -1;
  }

 private:
  bool atClamp(const octomap::OcTreeNode* node, float delta) const {
    const float v = node->getLogOdds();
    return (delta >= 0 && v >= clamp_max_) || (delta <= 0 && v <= clamp_min_);
  }

  // The walk has left the subtrees of the path nodes deeper than `depth`: nothing below them changes any
  // more in this scan, so settle them bottom-up as OctoMap's non-lazy update does after each change.
  void finishDownTo(int depth) {
    for (int d = valid_; d > depth; --d) {
      octomap::OcTreeNode* node = path_[d];
      if (d == static_cast<int>(kTreeDepth) || !tree_.nodeHasChildren(node)) continue;
      if (!tree_.pruneNode(node)) node->updateOccupancyChildren();
    }
    valid_ = std::min(valid_, depth);
  }

  octomap::OcTree& tree_;
  const float hit_, miss_, clamp_min_, clamp_max_;
  std::array<octomap::OcTreeNode*, kTreeDepth + 1> path_{};
  std::array<bool, kTreeDepth + 1> fresh_{};
  int valid_ = -1;  // path_[0..valid_] is the path of the previous voxel
  std::uint64_t previous_ = 0;
  bool has_previous_ = false;
};

// One thread's share of OccupancyOcTreeBase::computeUpdate, with the same tests in the same precision.
void markRays(const octomap::OcTree& tree, const octomap::point3d* points, std::size_t count,
              const octomap::point3d& origin, double max_range, BrickMap& map) {
  octomap::KeyRay ray;
  octomap::OcTreeKey key;
  for (std::size_t i = 0; i < count; ++i) {
    const octomap::point3d& p = points[i];
    if (max_range < 0.0 || (p - origin).norm() <= max_range) {
      if (tree.computeRayKeys(origin, p, ray)) {
        for (const octomap::OcTreeKey& k : ray) map.markFree(k);
      }
      if (tree.coordToKeyChecked(p, key)) map.markOccupied(key);
    } else {
      const octomap::point3d direction = (p - origin).normalized();
      const octomap::point3d new_end = origin + direction * static_cast<float>(max_range);
      if (tree.computeRayKeys(origin, new_end, ray)) {
        for (const octomap::OcTreeKey& k : ray) map.markFree(k);
      }
    }
  }
}

}  // namespace

void BrickMap::clear() {
  bricks_.clear();
  std::fill(slot_keys_.begin(), slot_keys_.end(), kEmpty);
  cached_packed_ = kEmpty;
}

std::uint32_t BrickMap::findOrAdd(std::uint64_t packed) {
  if ((bricks_.size() + 1) * 2 > slot_keys_.size()) grow();
  const std::size_t mask = slot_keys_.size() - 1;
  for (std::size_t s = slotOf(packed, mask);; s = (s + 1) & mask) {
    if (slot_keys_[s] == packed) return slot_bricks_[s];
    if (slot_keys_[s] == kEmpty) {
      slot_keys_[s] = packed;
      slot_bricks_[s] = static_cast<std::uint32_t>(bricks_.size());
      Brick& b = bricks_.emplace_back();
      std::memset(&b, 0, sizeof(Brick));
      b.morton = brickMorton(packed);
      return slot_bricks_[s];
    }
  }
}

void BrickMap::grow() {
  const std::size_t capacity = std::max<std::size_t>(1024, slot_keys_.size() * 2);
  slot_keys_.assign(capacity, kEmpty);
  slot_bricks_.assign(capacity, 0);
  const std::size_t mask = capacity - 1;
  // Re-derive the packed coordinates from each brick's Morton code.
  for (std::uint32_t i = 0; i < bricks_.size(); ++i) {
    const octomap::OcTreeKey k = keyOfMorton(bricks_[i].morton << 9);
    const std::uint64_t packed = packBrick(k);
    std::size_t s = slotOf(packed, mask);
    while (slot_keys_[s] != kEmpty) s = (s + 1) & mask;
    slot_keys_[s] = packed;
    slot_bricks_[s] = i;
  }
}

void BrickMap::bitsFor(const octomap::OcTreeKey& key, bool occupied) {
  const std::uint64_t packed = packBrick(key);
  if (packed != cached_packed_) {
    cached_brick_ = findOrAdd(packed);
    cached_packed_ = packed;
  }
  Brick& b = bricks_[cached_brick_];
  const std::uint32_t bit = localIndex(key);
  (occupied ? b.occupied : b.free)[bit >> 6] |= 1ull << (bit & 63);
}

void BrickMap::mergeFrom(const BrickMap& other) {
  for (const Brick& src : other.bricks_) {
    const octomap::OcTreeKey k = keyOfMorton(src.morton << 9);
    Brick& dst = bricks_[findOrAdd(packBrick(k))];
    for (int w = 0; w < 8; ++w) {
      dst.free[w] |= src.free[w];
      dst.occupied[w] |= src.occupied[w];
    }
  }
  cached_packed_ = kEmpty;
}

std::size_t BrickMap::memoryUsage() const {
  return slot_keys_.capacity() * sizeof(std::uint64_t) + slot_bricks_.capacity() * sizeof(std::uint32_t) +
         bricks_.capacity() * sizeof(Brick);
}

InsertCounts FastInserter::insert(octomap::OcTree& tree, const std::vector<octomap::point3d>& points,
                                  const octomap::point3d& origin, double max_range, bool discretize, int threads) {
  const std::vector<octomap::point3d>* cloud = &points;
  if (discretize) {
    // OccupancyOcTreeBase::computeDiscreteUpdate: one ray per distinct end voxel, to the voxel centre.
    sort_buffer_.clear();
    sort_buffer_.reserve(points.size());
    for (const octomap::point3d& p : points) {
      const octomap::OcTreeKey k = tree.coordToKey(p);
      sort_buffer_.push_back(std::uint64_t(k[0]) | (std::uint64_t(k[1]) << 16) | (std::uint64_t(k[2]) << 32));
    }
    std::sort(sort_buffer_.begin(), sort_buffer_.end());
    sort_buffer_.erase(std::unique(sort_buffer_.begin(), sort_buffer_.end()), sort_buffer_.end());
    discrete_points_.clear();
    for (std::uint64_t packed : sort_buffer_) {
      const octomap::OcTreeKey k(packed & 0xffff, (packed >> 16) & 0xffff, (packed >> 32) & 0xffff);
      discrete_points_.push_back(tree.keyToCoord(k));
    }
    cloud = &discrete_points_;
  }

  // 1. Ray keys, one contiguous share of the points per thread (lidar points are ordered by beam, so a
  //    share is an angular sector and its rays are coherent).
  const int n_threads = std::clamp<int>(threads, 1, 64);
  if (maps_.size() < static_cast<std::size_t>(n_threads)) maps_.resize(n_threads);
  for (BrickMap& m : maps_) m.clear();
  const std::size_t n = cloud->size();
  if (n_threads == 1 || n < 2048) {
    markRays(tree, cloud->data(), n, origin, max_range, maps_[0]);
  } else {
    std::vector<std::thread> workers;
    const std::size_t share = (n + n_threads - 1) / n_threads;
    for (int t = 1; t < n_threads; ++t) {
      const std::size_t begin = std::min(n, share * t), end = std::min(n, share * (t + 1));
      workers.emplace_back(
          [&, begin, end, t] { markRays(tree, cloud->data() + begin, end - begin, origin, max_range, maps_[t]); });
    }
    markRays(tree, cloud->data(), std::min(n, share), origin, max_range, maps_[0]);
    for (std::thread& w : workers) w.join();
    for (int t = 1; t < n_threads; ++t) maps_[0].mergeFrom(maps_[t]);
  }

  // 2. Occupied wins over free; bricks in Morton order.
  std::vector<BrickMap::Brick>& bricks = maps_[0].bricks();
  InsertCounts counts;
  for (BrickMap::Brick& b : bricks) {
    for (int w = 0; w < 8; ++w) {
      b.free[w] &= ~b.occupied[w];
      counts.free_cells += std::popcount(b.free[w]);
      counts.occupied_cells += std::popcount(b.occupied[w]);
    }
  }
  if (counts.free_cells + counts.occupied_cells == 0) return counts;  // OctoMap creates no root then
  sort_buffer_.clear();
  for (std::uint32_t i = 0; i < bricks.size(); ++i) sort_buffer_.push_back((bricks[i].morton << 24) | i);
  std::sort(sort_buffer_.begin(), sort_buffer_.end());

  // 3. One depth-first walk over the updated voxels.
  TreeWalk walk(tree);
  for (std::uint64_t entry : sort_buffer_) {
    const BrickMap::Brick& b = bricks[entry & 0xffffff];
    const std::uint64_t base = b.morton << 9;
    for (int w = 0; w < 8; ++w) {
      std::uint64_t any = b.free[w] | b.occupied[w];
      while (any != 0) {
        const unsigned bit = static_cast<unsigned>(std::countr_zero(any));
        any &= any - 1;
        walk.update(base | (static_cast<std::uint64_t>(w) << 6) | bit, (b.occupied[w] >> bit) & 1u);
      }
    }
  }
  walk.finish();
  return counts;
}

std::size_t FastInserter::memoryUsage() const {
  std::size_t bytes = discrete_points_.capacity() * sizeof(octomap::point3d) +
                      sort_buffer_.capacity() * sizeof(std::uint64_t);
  for (const BrickMap& m : maps_) bytes += m.memoryUsage();
  return bytes;
}

void FastInserter::releaseScratch() {
  maps_.clear();
  maps_.shrink_to_fit();
  discrete_points_ = {};
  sort_buffer_ = {};
}

}  // namespace ddsnav::mapper::detail
