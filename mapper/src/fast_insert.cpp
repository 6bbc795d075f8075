#include "fast_insert.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <thread>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace ddsnav::mapper::detail {
namespace {

constexpr std::uint64_t kEmpty = ~0ull;
constexpr unsigned kTreeDepth = 16;  // OcTree keys are 16 bits per axis
constexpr int kBrickDepth = 13;      // the depth of an 8x8x8-voxel brick's node

// Spreads the 16 bits of v to every third bit (bit i to bit 3i).
constexpr std::uint64_t spread16(std::uint64_t v) {
  v &= 0xffff;
  v = (v | (v << 16)) & 0x0000ff0000ffull;
  v = (v | (v << 8)) & 0x00f00f00f00full;
  v = (v | (v << 4)) & 0x0c30c30c30c3ull;
  v = (v | (v << 2)) & 0x249249249249ull;
  return v;
}

// Inverse of spread16: every third bit of v, from bit 0, gathered into the low 16 bits.
constexpr std::uint64_t compact16(std::uint64_t v) {
  v &= 0x249249249249ull;
  v = (v | (v >> 2)) & 0x0c30c30c30c3ull;
  v = (v | (v >> 4)) & 0x00f00f00f00full;
  v = (v | (v >> 8)) & 0x0000ff0000ffull;
  v = (v | (v >> 16)) & 0xffff;
  return v;
}

// The code bits of one axis in a Morton code.
constexpr std::uint64_t kAxisBits[3] = {0x249249249249ull, 0x249249249249ull << 1, 0x249249249249ull << 2};

std::size_t slotOf(std::uint64_t brick_code, std::size_t mask) {
  return static_cast<std::size_t>((brick_code * 0x9E3779B97F4A7C15ull) >> 20) & mask;
}

// Inverse of BrickMap's in-brick index: bit i of the 9-bit Morton index -> (x, y, z) offsets.
struct LocalOffsets {
  std::array<std::uint8_t, 512> x{}, y{}, z{};
  constexpr LocalOffsets() {
    for (unsigned i = 0; i < 512; ++i) {
      x[i] = static_cast<std::uint8_t>(((i >> 0) & 1) | (((i >> 3) & 1) << 1) | (((i >> 6) & 1) << 2));
      y[i] = static_cast<std::uint8_t>(((i >> 1) & 1) | (((i >> 4) & 1) << 1) | (((i >> 7) & 1) << 2));
      z[i] = static_cast<std::uint8_t>(((i >> 2) & 1) | (((i >> 5) & 1) << 1) | (((i >> 8) & 1) << 2));
    }
  }
};
constexpr LocalOffsets kLocal;

unsigned childIndex(const octomap::OcTreeKey& k, unsigned level) {
  return ((k[0] >> level) & 1u) | (((k[1] >> level) & 1u) << 1) | (((k[2] >> level) & 1u) << 2);
}

// OcTreeBaseImpl keeps the root pointer, the node count and a node's child array protected; a pointer to
// member formed inside a derived class reaches them without changing any type (the tree stays a plain
// OcTree, so writeBinary and every OctoMap tool see the usual "OcTree").
struct TreeAccess : octomap::OcTree {
  static octomap::OcTreeNode*& rootOf(octomap::OcTree& t) { return t.*(&TreeAccess::root); }
  static std::size_t& sizeOf(octomap::OcTree& t) { return t.*(&TreeAccess::tree_size); }
  static bool& sizeChangedOf(octomap::OcTree& t) { return t.*(&TreeAccess::size_changed); }
};
struct NodeAccess : octomap::OcTreeNode {
  static octomap::AbstractOcTreeNode**& childrenOf(octomap::OcTreeNode& n) { return n.*(&NodeAccess::children); }
};

// OcTreeBaseImpl::createNodeChild / expandNode / pruneNode, with two differences: the change in node
// count goes to a per-thread counter instead of the tree's (so disjoint subtrees can be updated from
// several threads; the caller adds the counters to the tree afterwards), and the nodes and child arrays a
// prune frees are kept for the next nodes this walk creates instead of going back to malloc (a walk prunes
// and creates in the same regions; glibc's free + malloc of them was a good part of the walk's time). What
// is left over goes back with delete when the walk ends: every node in the tree still comes from `new`.
class alignas(64) NodeOps {  // one cache line each: the per-thread counters are written on every new node
 public:
  explicit NodeOps(const octomap::OcTree& tree) : tree_(tree) {}
  NodeOps(const NodeOps&) = delete;
  NodeOps& operator=(const NodeOps&) = delete;
  ~NodeOps() {
    for (octomap::OcTreeNode* node : spare_nodes_) delete node;
    for (octomap::AbstractOcTreeNode** children : spare_arrays_) delete[] children;
  }

  octomap::OcTreeNode* createChild(octomap::OcTreeNode* node, unsigned pos) {
    octomap::AbstractOcTreeNode**& children = NodeAccess::childrenOf(*node);
    if (children == nullptr) {
      if (spare_arrays_.empty()) {
        children = new octomap::AbstractOcTreeNode*[8];
      } else {
        children = spare_arrays_.back();
        spare_arrays_.pop_back();
      }
      for (unsigned i = 0; i < 8; ++i) children[i] = nullptr;
    }
    octomap::OcTreeNode* child;
    if (spare_nodes_.empty()) {
      child = new octomap::OcTreeNode();
    } else {
      child = spare_nodes_.back();  // a pruned leaf: no children, so ending its life frees nothing
      spare_nodes_.pop_back();
      child->~OcTreeNode();
      new (child) octomap::OcTreeNode();
    }
    children[pos] = child;
    ++node_delta_;
    return child;
  }
  void expand(octomap::OcTreeNode* node) {
    for (unsigned k = 0; k < 8; ++k) createChild(node, k)->copyData(*node);
  }
  bool prune(octomap::OcTreeNode* node) {
    if (!tree_.isNodeCollapsible(node)) return false;
    node->copyData(*tree_.getNodeChild(node, 0));
    octomap::AbstractOcTreeNode**& children = NodeAccess::childrenOf(*node);
    for (unsigned i = 0; i < 8; ++i) {
      auto* child = static_cast<octomap::OcTreeNode*>(children[i]);  // a leaf (isNodeCollapsible)
      if (spare_nodes_.size() < kMaxSpareNodes) {
        spare_nodes_.push_back(child);
      } else {
        delete child;
      }
      children[i] = nullptr;
    }
    if (spare_arrays_.size() < kMaxSpareNodes / 8) {
      spare_arrays_.push_back(children);
    } else {
      delete[] children;
    }
    children = nullptr;
    node_delta_ -= 8;
    return true;
  }
  // Settles a node whose subtree will not change any more: pruned when its 8 children are equal leaves,
  // else given the max of its children (OctoMap's non-lazy update does this after every change).
  void settle(octomap::OcTreeNode* node) {
    if (!tree_.nodeHasChildren(node)) return;
    if (!prune(node)) node->updateOccupancyChildren();
  }
  long nodeDelta() const { return node_delta_; }

 private:
  static constexpr std::size_t kMaxSpareNodes = 1 << 16;  // 1 MB of nodes at most, per thread
  const octomap::OcTree& tree_;
  long node_delta_ = 0;
  std::vector<octomap::OcTreeNode*> spare_nodes_;
  std::vector<octomap::AbstractOcTreeNode**> spare_arrays_;
};

// The walk over Morton-ordered voxels described in fast_insert.hpp, below one subtree root.
class TreeWalk {
 public:
  // `changed_regions` (may be null): where a voxel changes class, its region is appended (once per run of
  // voxels in one region, the walk's order keeps them together).
  TreeWalk(const octomap::OcTree& tree, NodeOps& ops, std::vector<std::uint64_t>* changed_regions, const FreeDiscoveryRule& free_discovery)
      : tree_(tree),
        ops_(ops),
        changed_regions_(changed_regions),
        free_discovery_(free_discovery),
        hit_(tree.getProbHitLog()),
        miss_(tree.getProbMissLog()),
        clamp_min_(tree.getClampingThresMinLog()),
        clamp_max_(tree.getClampingThresMaxLog()) {}

  // Starts a subtree: `node` sits at `depth` and every following voxel lies below it. `fresh`: the node
  // was created in this scan (a childless fresh node gets children created, not expanded).
  void begin(octomap::OcTreeNode* node, int depth, bool fresh) {
    base_ = valid_ = depth;
    path_[depth] = node;
    fresh_[depth] = fresh;
    has_previous_ = false;
  }

  // Updates the voxel `key` (Morton code `morton`). With `leaf_depth` kBrickDepth, updates the whole 8x8x8
  // brick of voxels [morton, last_morton] as its node at that depth, which must have no children (see
  // walkBricks).
  // `fill`: a voxel of the surface fill (FillMode); `occupied` is then ignored.
  void update(std::uint64_t morton, const octomap::OcTreeKey& key, bool occupied, int leaf_depth = kTreeDepth,
              std::uint64_t last_morton = 0, FillMode fill = FillMode::none) {
    int keep = base_;
    if (has_previous_) {
      const unsigned level = (63u - static_cast<unsigned>(std::countl_zero(morton ^ previous_))) / 3u;
      keep = std::max(keep, static_cast<int>(kTreeDepth - 1 - level));  // deepest shared ancestor
    }
    previous_ = leaf_depth == static_cast<int>(kTreeDepth) ? morton : last_morton;
    has_previous_ = true;
    keep = std::min(keep, valid_);
    settleDownTo(keep);

    // A fill voxel takes a hit unless it was observed free with confidence before this scan; then the scan's own
    // miss if its rays crossed it, else nothing (fillUpdate).
    float delta = fill != FillMode::none ? hit_ : occupied ? hit_ : miss_;
    const auto decideFill = [&](const octomap::OcTreeNode* observed) {
      const std::optional<bool> hit = fillUpdate(observed == nullptr ? std::nullopt : std::optional(observed->getLogOdds()),
                                                 fill == FillMode::over_free, miss_);
      if (hit) delta = *hit ? hit_ : miss_;
      return hit.has_value();
    };
    int d = keep;
    octomap::OcTreeNode* node = path_[d];
    while (d < leaf_depth) {
      const unsigned pos = childIndex(key, kTreeDepth - 1 - d);
      bool created = false;
      if (!tree_.nodeChildExists(node, pos)) {
        if (!tree_.nodeHasChildren(node) && !fresh_[d]) {
          // A pruned leaf: OctoMap's updateNode() finds it with search() and stops early when the
          // update cannot change it.
          if ((fill != FillMode::none && !decideFill(node)) || atClamp(node, delta)) {
            valid_ = d;
            return;
          }
          fill = FillMode::none;  // decided
          ops_.expand(node);
        } else {
          ops_.createChild(node, pos);
          created = true;
        }
      }
      node = tree_.getNodeChild(node, pos);
      ++d;
      path_[d] = node;
      fresh_[d] = created;
    }
    valid_ = d;
    if (fill != FillMode::none && !decideFill(fresh_[d] ? nullptr : node)) {
      if (fresh_[d]) changed(morton, key, /*free_discovery=*/false);  // a new node (never so for a fill: it takes a hit)
      return;
    }
    if (!fresh_[d] && atClamp(node, delta)) return;
    const bool was_occupied = tree_.isNodeOccupied(node);
    tree_.updateNodeLogOdds(node, delta);
    const bool occupied_now = tree_.isNodeOccupied(node);
    if (fresh_[d]) changed(morton, key, /*free_discovery=*/!occupied_now);  // was unknown
    else if (occupied_now != was_occupied) changed(morton, key, false);
  }

  // Whether the node of the brick holding `key` (depth kBrickDepth) exists and has children. Reads only
  // nodes below this walk's subtree root, so it is safe while other threads walk other subtrees.
  bool brickNodeHasChildren(const octomap::OcTreeKey& key) const {
    const octomap::OcTreeNode* node = path_[base_];
    for (int d = base_; d < kBrickDepth; ++d) {
      const unsigned pos = childIndex(key, kTreeDepth - 1 - d);
      if (!tree_.nodeChildExists(node, pos)) return false;
      node = tree_.getNodeChild(node, pos);
    }
    return tree_.nodeHasChildren(node);
  }

  // Settles every node still on the path, the subtree root included.
  void finish() { settleDownTo(base_ - 1); }

 private:
  void changed(std::uint64_t morton, const octomap::OcTreeKey& key, bool free_discovery) {
    if (changed_regions_ == nullptr) return;
    if (free_discovery && free_discovery_.near_keys > 0) {
      const auto off = [&](int a) { return std::abs(int(key[a]) - int(free_discovery_.origin[a])); };
      if (std::max({off(0), off(1), off(2)}) <= free_discovery_.near_keys) free_discovery = false;
    }
    const std::uint64_t region = changeRegionOf(morton) | (free_discovery ? kFreeDiscoveryOnly : 0);
    if (changed_regions_->empty() || changed_regions_->back() != region) changed_regions_->push_back(region);
  }

  bool atClamp(const octomap::OcTreeNode* node, float delta) const {
    const float v = node->getLogOdds();
    return (delta >= 0 && v >= clamp_max_) || (delta <= 0 && v <= clamp_min_);
  }

  // The walk has left the subtrees of the path nodes deeper than `depth`: settle them bottom-up.
  void settleDownTo(int depth) {
    for (int d = valid_; d > depth; --d) {
      if (d < static_cast<int>(kTreeDepth)) ops_.settle(path_[d]);
    }
    valid_ = std::min(valid_, depth);
  }

  const octomap::OcTree& tree_;
  NodeOps& ops_;
  std::vector<std::uint64_t>* changed_regions_;
  const FreeDiscoveryRule free_discovery_;
  const float hit_, miss_, clamp_min_, clamp_max_;
  std::array<octomap::OcTreeNode*, kTreeDepth + 1> path_{};
  std::array<bool, kTreeDepth + 1> fresh_{};
  int base_ = 0;
  int valid_ = 0;  // path_[base_..valid_] is the path of the previous voxel
  std::uint64_t previous_ = 0;
  bool has_previous_ = false;
};

// Feeds the voxels of Morton-sorted bricks [first, last) to a walk.
//
// A brick whose 512 voxels all get a miss (near the sensor, where rays are dense: 15 % of the cells of a
// 64x1800 scan at 0.1 m, 28 % at 0.2 m) is updated as one node when its node has no children. Voxel by
// voxel, OctoMap would give every voxel the same value — a new node's 0 + miss, or the pruned leaf's
// value + miss, clamped, or nothing when that leaf is already clamped — and then prune the brick back to one
// leaf at its depth: exactly the node this sets, with the same arithmetic (`updateNodeLogOdds` once).
void walkBricks(const std::vector<BrickMap::Brick>& bricks, const std::uint64_t* first, const std::uint64_t* last,
                TreeWalk& walk) {
  for (const std::uint64_t* e = first; e != last; ++e) {
    const BrickMap::Brick& b = bricks[*e & 0xffffff];
    const std::uint64_t base = b.morton << 9;
    const unsigned kx = unsigned(b.bx) << 3, ky = unsigned(b.by) << 3, kz = unsigned(b.bz) << 3;
    const octomap::OcTreeKey brick_key(static_cast<octomap::key_type>(kx), static_cast<octomap::key_type>(ky),
                                       static_cast<octomap::key_type>(kz));
    bool all_free = true;
    for (unsigned w = 0; w < 8; ++w) all_free &= b.free[w] == ~0ull && b.fill[w] == 0;
    if (all_free && !walk.brickNodeHasChildren(brick_key)) {
      walk.update(base, brick_key, false, kBrickDepth, base | 511);
      continue;
    }
    for (unsigned w = 0; w < 8; ++w) {
      std::uint64_t any = b.free[w] | b.occupied[w] | b.fill[w];
      while (any != 0) {
        const unsigned local = (w << 6) | static_cast<unsigned>(std::countr_zero(any));
        any &= any - 1;
        const octomap::OcTreeKey key(static_cast<octomap::key_type>(kx | kLocal.x[local]),
                                     static_cast<octomap::key_type>(ky | kLocal.y[local]),
                                     static_cast<octomap::key_type>(kz | kLocal.z[local]));
        const unsigned bit = local & 63;
        const bool occupied = (b.occupied[w] >> bit) & 1u;
        const FillMode fill = occupied || !((b.fill[w] >> bit) & 1u) ? FillMode::none
                              : ((b.free[w] >> bit) & 1u)           ? FillMode::over_free
                                                                    : FillMode::only;
        walk.update(base | local, key, occupied, kTreeDepth, 0, fill);
      }
    }
  }
}

// A run of sorted bricks below one tree node at the split depth, handed to one thread.
struct Subtree {
  std::size_t first = 0, last = 0;  // into the sorted brick list
  std::size_t cells = 0;
  octomap::OcTreeNode* node = nullptr;
  bool fresh = false;
};

// Applies the sorted bricks to the tree: on one thread as one walk from the root, or on several, each
// walking whole subtrees below a split depth after the paths down to that depth exist.
// Returns the number of threads that walked.
int applyToTree(octomap::OcTree& tree, const std::vector<BrickMap::Brick>& bricks,
                const std::vector<std::uint64_t>& sorted, std::size_t cells, int threads,
                std::vector<std::uint64_t>* changed_regions, const FreeDiscoveryRule& free_discovery) {
  octomap::OcTreeNode*& root = TreeAccess::rootOf(tree);
  NodeOps main_ops(tree);
  bool root_fresh = false;
  if (root == nullptr) {
    root = new octomap::OcTreeNode();
    ++TreeAccess::sizeOf(tree);
    root_fresh = true;
  }
  TreeAccess::sizeChangedOf(tree) = true;

  // Split depth: the shallowest depth (<= 12, a 2^4-voxel cube) whose subtrees number at least 8 per
  // thread, so the shares can be balanced.
  std::vector<Subtree> subtrees;
  int split_depth = 0;
  if (threads > 1 && cells >= 16384) {
    for (int depth = 1; depth <= 12; ++depth) {
      const unsigned shift = 3u * (13u - depth);  // brick Morton codes cover depths 1..13
      subtrees.clear();
      for (std::size_t i = 0; i < sorted.size(); ++i) {
        const std::uint64_t prefix = bricks[sorted[i] & 0xffffff].morton >> shift;
        if (subtrees.empty() || (bricks[sorted[subtrees.back().first] & 0xffffff].morton >> shift) != prefix) {
          if (!subtrees.empty()) subtrees.back().last = i;
          subtrees.push_back({i, i, 0, nullptr, false});
        }
        const BrickMap::Brick& b = bricks[sorted[i] & 0xffffff];
        for (int w = 0; w < 8; ++w) subtrees.back().cells += std::popcount(b.free[w] | b.occupied[w] | b.fill[w]);
      }
      if (!subtrees.empty()) subtrees.back().last = sorted.size();
      if (subtrees.size() >= 8u * threads) {
        split_depth = depth;
        break;
      }
    }
  }

  // Paths from the root down to every subtree node, created where missing. A pruned leaf above the split
  // depth would need OctoMap's early-abort/expand logic for a whole share: then stay on one thread.
  auto keyOf = [&](const Subtree& st) {
    const BrickMap::Brick& b = bricks[sorted[st.first] & 0xffffff];
    return octomap::OcTreeKey(static_cast<octomap::key_type>(b.bx << 3), static_cast<octomap::key_type>(b.by << 3),
                              static_cast<octomap::key_type>(b.bz << 3));
  };
  for (const Subtree& st : subtrees) {  // read-only check first: nothing may change before the fallback
    if (split_depth == 0) break;
    const octomap::OcTreeKey key = keyOf(st);
    const octomap::OcTreeNode* node = root;
    for (int d = 0; d < split_depth; ++d) {
      const unsigned pos = childIndex(key, kTreeDepth - 1 - d);
      if (tree.nodeChildExists(node, pos)) {
        node = tree.getNodeChild(node, pos);
        continue;
      }
      if (!tree.nodeHasChildren(node) && !(d == 0 && root_fresh)) split_depth = 0;  // a pruned leaf
      break;  // below a missing child everything is new
    }
  }
  std::vector<std::vector<octomap::OcTreeNode*>> above(split_depth);  // nodes to settle, per depth
  if (split_depth > 0) {
    for (Subtree& st : subtrees) {
      const octomap::OcTreeKey key = keyOf(st);
      octomap::OcTreeNode* node = root;
      bool fresh = root_fresh;
      for (int d = 0; d < split_depth; ++d) {
        if (above[d].empty() || above[d].back() != node) above[d].push_back(node);
        const unsigned pos = childIndex(key, kTreeDepth - 1 - d);
        fresh = !tree.nodeChildExists(node, pos);
        if (fresh) main_ops.createChild(node, pos);
        node = tree.getNodeChild(node, pos);
      }
      st.node = node;
      st.fresh = fresh;
    }
  }

  if (split_depth == 0) {
    TreeWalk walk(tree, main_ops, changed_regions, free_discovery);
    walk.begin(root, 0, root_fresh);
    walkBricks(bricks, sorted.data(), sorted.data() + sorted.size(), walk);
    walk.finish();
    TreeAccess::sizeOf(tree) += main_ops.nodeDelta();
    return 1;
  }

  // Threads take subtrees from a shared counter, so a thread the OS delays (2 cores shared with other
  // processes) holds up at most one subtree instead of a fixed share.
  std::vector<std::unique_ptr<NodeOps>> ops;
  for (int t = 0; t < threads; ++t) ops.push_back(std::make_unique<NodeOps>(tree));
  std::vector<std::vector<std::uint64_t>> thread_changes(changed_regions != nullptr ? threads : 0);
  std::atomic<std::size_t> next{0};
  auto work = [&](int t) {
    TreeWalk walk(tree, *ops[t], changed_regions != nullptr ? &thread_changes[t] : nullptr, free_discovery);
    for (std::size_t i = next.fetch_add(1); i < subtrees.size(); i = next.fetch_add(1)) {
      const Subtree& st = subtrees[i];
      walk.begin(st.node, split_depth, st.fresh);
      walkBricks(bricks, sorted.data() + st.first, sorted.data() + st.last, walk);
      walk.finish();
    }
  };
  std::vector<std::thread> workers;
  for (int t = 1; t < threads; ++t) workers.emplace_back(work, t);
  work(0);
  for (std::thread& w : workers) w.join();
  for (const std::vector<std::uint64_t>& c : thread_changes) changed_regions->insert(changed_regions->end(), c.begin(), c.end());

  // The nodes above the split, deepest first, once their subtrees are final.
  for (int d = split_depth - 1; d >= 0; --d) {
    for (octomap::OcTreeNode* node : above[d]) main_ops.settle(node);
  }
  long delta = main_ops.nodeDelta();
  for (const auto& o : ops) delta += o->nodeDelta();
  TreeAccess::sizeOf(tree) += delta;
  return threads;
}

// OcTreeBaseImpl::computeRayKeys, statement for statement and in the same precision (float vectors, double
// tMax / tDelta), but marking the keys straight into the brick map instead of a KeyRay. Returns false, marking
// nothing, when the end point is outside the map (the origin was checked by the caller).
//
// The loop is where the mapper spends most of its time, so each step is as few instructions as the exact
// arithmetic allows:
// - the current key is kept as its Morton code: stepping one axis by +-1 is an add on that axis's bits with
//   the other bits filled with ones to carry across them (so each axis still wraps at 16 bits, as the key's
//   uint16 does), the end test is one compare, and the brick and in-brick bit of the mark are a shift and a
//   mask;
// - the axis is chosen with the same comparisons as OctoMap's if/else (ties included), as all-ones/zero masks,
//   without branches (the axis is close to random from step to step, so branches would mispredict about half
//   the time); the chosen tMax gets tDelta added, the others +0.0, which leaves them unchanged.
bool traceRay(const octomap::OcTree& tree, const octomap::point3d& origin, const octomap::OcTreeKey& key_origin,
              std::uint64_t code_origin, const octomap::point3d& end, BrickMap& map) {
  octomap::OcTreeKey key_end;
  if (!tree.coordToKeyChecked(end, key_end)) return false;
  if (key_origin == key_end) return true;  // same cell: no free cells
  BrickMap::Cursor cursor;
  map.markFree(code_origin, cursor);

  octomap::point3d direction = (end - origin);
  const float length = static_cast<float>(direction.norm());
  direction /= length;
  const double resolution = tree.getResolution();
  double t_max[3], t_delta[3];
  std::uint64_t axis_step[3];  // +1 or -1 on the axis's bits: 1 << axis, or all of the axis's bits (0xffff)
  for (unsigned i = 0; i < 3; ++i) {
    const int step = direction(i) > 0.0 ? 1 : (direction(i) < 0.0 ? -1 : 0);
    axis_step[i] = step > 0 ? (1ull << i) : (step < 0 ? kAxisBits[i] : 0);
    if (step != 0) {
      double voxel_border = tree.keyToCoord(key_origin[i]);
      voxel_border += static_cast<float>(step * resolution * 0.5);
      t_max[i] = (voxel_border - origin(i)) / direction(i);
      t_delta[i] = resolution / std::fabs(direction(i));
    } else {
      t_max[i] = std::numeric_limits<double>::max();
      t_delta[i] = std::numeric_limits<double>::max();
    }
  }
  const std::uint64_t code_end = mortonCode(key_end);
  std::uint64_t code = code_origin;
#if defined(__SSE2__)
  __m128d t0 = _mm_set_sd(t_max[0]), t1 = _mm_set_sd(t_max[1]), t2 = _mm_set_sd(t_max[2]);
  const __m128d dt0 = _mm_set_sd(t_delta[0]), dt1 = _mm_set_sd(t_delta[1]), dt2 = _mm_set_sd(t_delta[2]);
  const __m128d limit = _mm_set_sd(static_cast<double>(length));
  const __m128d ones = _mm_castsi128_pd(_mm_set1_epi64x(-1));
  const __m128i bits0 = _mm_set_epi64x(0, static_cast<long long>(kAxisBits[0]));
  const __m128i bits1 = _mm_set_epi64x(0, static_cast<long long>(kAxisBits[1]));
  const __m128i bits2 = _mm_set_epi64x(0, static_cast<long long>(kAxisBits[2]));
  const __m128i step0 = _mm_set_epi64x(0, static_cast<long long>(axis_step[0]));
  const __m128i step1 = _mm_set_epi64x(0, static_cast<long long>(axis_step[1]));
  const __m128i step2 = _mm_set_epi64x(0, static_cast<long long>(axis_step[2]));
  while (true) {
    const __m128d c01 = _mm_cmplt_sd(t0, t1), c02 = _mm_cmplt_sd(t0, t2), c12 = _mm_cmplt_sd(t1, t2);
    const __m128d d0 = _mm_and_pd(c01, c02);
    const __m128d d1 = _mm_andnot_pd(c01, c12);
    const __m128d d2 = _mm_andnot_pd(_mm_or_pd(d0, d1), ones);
    t0 = _mm_add_sd(t0, _mm_and_pd(dt0, d0));
    t1 = _mm_add_sd(t1, _mm_and_pd(dt1, d1));
    t2 = _mm_add_sd(t2, _mm_and_pd(dt2, d2));
    const __m128i i0 = _mm_castpd_si128(d0), i1 = _mm_castpd_si128(d1), i2 = _mm_castpd_si128(d2);
    const auto axis = static_cast<std::uint64_t>(_mm_cvtsi128_si64(
        _mm_or_si128(_mm_or_si128(_mm_and_si128(i0, bits0), _mm_and_si128(i1, bits1)), _mm_and_si128(i2, bits2))));
    const auto step = static_cast<std::uint64_t>(_mm_cvtsi128_si64(
        _mm_or_si128(_mm_or_si128(_mm_and_si128(i0, step0), _mm_and_si128(i1, step1)), _mm_and_si128(i2, step2))));
    code = (((code | ~axis) + step) & axis) | (code & ~axis);
    if (code == code_end) return true;
    // Past the end point's distance without reaching its key (rounding): stop, as OctoMap does.
    if (_mm_comigt_sd(_mm_min_sd(_mm_min_sd(t0, t1), t2), limit)) return true;
    map.markFree(code, cursor);
  }
#else
  double t0 = t_max[0], t1 = t_max[1], t2 = t_max[2];
  while (true) {
    const bool c01 = t0 < t1, c02 = t0 < t2, c12 = t1 < t2;
    const bool d0 = c01 & c02, d1 = !c01 & c12, d2 = !(d0 | d1);
    const std::uint64_t axis = kAxisBits[0] * d0 + kAxisBits[1] * d1 + kAxisBits[2] * d2;
    const std::uint64_t step = axis_step[0] * d0 + axis_step[1] * d1 + axis_step[2] * d2;
    code = (((code | ~axis) + step) & axis) | (code & ~axis);
    t0 += t_delta[0] * static_cast<double>(d0);
    t1 += t_delta[1] * static_cast<double>(d1);
    t2 += t_delta[2] * static_cast<double>(d2);
    if (code == code_end) return true;
    if (std::min(std::min(t0, t1), t2) > length) return true;
    map.markFree(code, cursor);
  }
#endif
}

// One thread's share of OccupancyOcTreeBase::computeUpdate, with the same tests in the same precision. With
// `clear_only` the points are ends of rays cleared up to them, whatever max_range, their end voxel not marked.
void markRays(const octomap::OcTree& tree, const octomap::point3d* points, std::size_t count,
              const octomap::point3d& origin, double max_range, BrickMap& map, bool clear_only = false) {
  octomap::OcTreeKey key_origin, key;
  if (!tree.coordToKeyChecked(origin, key_origin)) return;  // OctoMap: every ray fails
  const std::uint64_t code_origin = mortonCode(key_origin);
  for (std::size_t i = 0; i < count; ++i) {
    const octomap::point3d& p = points[i];
    if (clear_only) {
      traceRay(tree, origin, key_origin, code_origin, p, map);
    } else if (max_range < 0.0 || (p - origin).norm() <= max_range) {
      traceRay(tree, origin, key_origin, code_origin, p, map);
      if (tree.coordToKeyChecked(p, key)) map.markOccupied(key);
    } else {
      const octomap::point3d direction = (p - origin).normalized();
      const octomap::point3d new_end = origin + direction * static_cast<float>(max_range);
      traceRay(tree, origin, key_origin, code_origin, new_end, map);
    }
  }
}

}  // namespace

std::uint64_t mortonCode(const octomap::OcTreeKey& key) {
  return spread16(key[0]) | (spread16(key[1]) << 1) | (spread16(key[2]) << 2);
}

std::array<std::uint64_t, 6> faceNeighbourRegions(std::uint64_t region) {
  // A region's name interleaves its coordinates (the keys' high bits) as a voxel's Morton code does the keys.
  constexpr std::uint64_t kLast = (std::uint64_t(1) << (16 - kChangeRegionShift / 3)) - 1;
  const std::uint64_t at[3] = {compact16(region), compact16(region >> 1), compact16(region >> 2)};
  std::array<std::uint64_t, 6> out;
  out.fill(region);
  std::size_t n = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (const int side : {-1, 1}) {
      if ((side < 0 && at[axis] == 0) || (side > 0 && at[axis] == kLast)) continue;
      std::uint64_t c[3] = {at[0], at[1], at[2]};
      c[axis] = side < 0 ? c[axis] - 1 : c[axis] + 1;
      out[n++] = spread16(c[0]) | (spread16(c[1]) << 1) | (spread16(c[2]) << 2);
    }
  return out;
}

void BrickMap::clear() {
  bricks_.clear();
  std::fill(slot_keys_.begin(), slot_keys_.end(), kEmpty);
  cursor_ = Cursor{};
}

std::uint32_t BrickMap::findOrAdd(std::uint64_t brick_code) {
  if ((bricks_.size() + 1) * 2 > slot_keys_.size()) grow();
  const std::size_t mask = slot_keys_.size() - 1;
  for (std::size_t s = slotOf(brick_code, mask);; s = (s + 1) & mask) {
    if (slot_keys_[s] == brick_code) return slot_bricks_[s];
    if (slot_keys_[s] == kEmpty) {
      slot_keys_[s] = brick_code;
      slot_bricks_[s] = static_cast<std::uint32_t>(bricks_.size());
      Brick& b = bricks_.emplace_back();
      std::memset(&b, 0, sizeof(Brick));
      b.morton = brick_code;
      b.bx = static_cast<std::uint16_t>(compact16(brick_code));
      b.by = static_cast<std::uint16_t>(compact16(brick_code >> 1));
      b.bz = static_cast<std::uint16_t>(compact16(brick_code >> 2));
      return slot_bricks_[s];
    }
  }
}

void BrickMap::grow() {
  const std::size_t capacity = std::max<std::size_t>(1024, slot_keys_.size() * 2);
  slot_keys_.assign(capacity, kEmpty);
  slot_bricks_.assign(capacity, 0);
  const std::size_t mask = capacity - 1;
  for (std::uint32_t i = 0; i < bricks_.size(); ++i) {
    std::size_t s = slotOf(bricks_[i].morton, mask);
    while (slot_keys_[s] != kEmpty) s = (s + 1) & mask;
    slot_keys_[s] = bricks_[i].morton;
    slot_bricks_[s] = i;
  }
}

void BrickMap::mergeFrom(const BrickMap& other) {
  for (const Brick& src : other.bricks_) {
    Brick& dst = bricks_[findOrAdd(src.morton)];
    for (int w = 0; w < 8; ++w) {
      dst.free[w] |= src.free[w];
      dst.occupied[w] |= src.occupied[w];
      dst.fill[w] |= src.fill[w];
    }
  }
  cursor_ = Cursor{};
}

std::size_t BrickMap::memoryUsage() const {
  return slot_keys_.capacity() * sizeof(std::uint64_t) + slot_bricks_.capacity() * sizeof(std::uint32_t) +
         bricks_.capacity() * sizeof(Brick);
}

InsertCounts computeKeys(const octomap::OcTree& tree, const std::vector<octomap::point3d>& points,
                         const octomap::point3d& origin, double max_range, bool discretize, int threads,
                         ScanKeys& keys, const std::vector<octomap::point3d>* surface_cells,
                         const std::vector<octomap::point3d>* clear_rays) {
  const std::vector<octomap::point3d>* cloud = &points;
  std::vector<std::uint64_t>& sort_buffer = keys.sorted;
  if (discretize) {
    // OccupancyOcTreeBase::computeDiscreteUpdate: one ray per distinct end voxel, to the voxel centre.
    sort_buffer.clear();
    sort_buffer.reserve(points.size());
    for (const octomap::point3d& p : points) {
      const octomap::OcTreeKey k = tree.coordToKey(p);
      sort_buffer.push_back(std::uint64_t(k[0]) | (std::uint64_t(k[1]) << 16) | (std::uint64_t(k[2]) << 32));
    }
    std::sort(sort_buffer.begin(), sort_buffer.end());
    sort_buffer.erase(std::unique(sort_buffer.begin(), sort_buffer.end()), sort_buffer.end());
    keys.discrete_points.clear();
    for (std::uint64_t packed : sort_buffer) {
      const octomap::OcTreeKey k(packed & 0xffff, (packed >> 16) & 0xffff, (packed >> 32) & 0xffff);
      keys.discrete_points.push_back(tree.keyToCoord(k));
    }
    cloud = &keys.discrete_points;
  }

  using Clock = std::chrono::steady_clock;
  auto lap = [t = Clock::now()]() mutable {
    const auto now = Clock::now();
    const double s = std::chrono::duration<double>(now - t).count();
    t = now;
    return s;
  };
  InsertCounts counts;
  // 1. Ray keys. Threads take runs of consecutive points from a shared counter (lidar points are ordered
  //    by beam, so a run is a small angular sector with coherent rays); each marks into its own map.
  const int n_threads = std::clamp<int>(threads, 1, 64);
  std::vector<BrickMap>& maps = keys.maps;
  if (maps.size() < static_cast<std::size_t>(n_threads)) maps.resize(n_threads);
  for (BrickMap& m : maps) m.clear();
  // The scan's points, then the clear rays: one index space [0, n + m), so that both are shared between threads.
  const std::size_t n = cloud->size(), m = clear_rays != nullptr ? clear_rays->size() : 0;
  const auto mark = [&](std::size_t begin, std::size_t end, BrickMap& map) {
    if (begin < n) markRays(tree, cloud->data() + begin, std::min(end, n) - begin, origin, max_range, map);
    if (end > n) {
      const std::size_t from = std::max(begin, n) - n;
      markRays(tree, clear_rays->data() + from, end - n - from, origin, max_range, map, /*clear_only=*/true);
    }
  };
  if (n_threads == 1 || n + m < 2048) {
    mark(0, n + m, maps[0]);
  } else {
    constexpr std::size_t kRun = 512;
    std::atomic<std::size_t> next{0};
    auto work = [&](int t) {
      for (std::size_t begin = next.fetch_add(kRun); begin < n + m; begin = next.fetch_add(kRun)) {
        mark(begin, std::min(begin + kRun, n + m), maps[t]);
      }
    };
    std::vector<std::thread> workers;
    for (int t = 1; t < n_threads; ++t) workers.emplace_back(work, t);
    work(0);
    for (std::thread& w : workers) w.join();
    counts.seconds_rays = lap();
    for (int t = 1; t < n_threads; ++t) maps[0].mergeFrom(maps[t]);
  }
  if (surface_cells != nullptr) {
    octomap::OcTreeKey key;
    for (const octomap::point3d& p : *surface_cells)
      if (tree.coordToKeyChecked(p, key)) maps[0].markFill(key);
  }
  if (counts.seconds_rays == 0.0) counts.seconds_rays = lap();

  // 2. Occupied wins over free; bricks in Morton order.
  std::vector<BrickMap::Brick>& bricks = maps[0].bricks();
  for (BrickMap::Brick& b : bricks) {
    for (int w = 0; w < 8; ++w) {
      b.free[w] &= ~b.occupied[w];
      b.fill[w] &= ~b.occupied[w];  // a return there: a plain hit
      counts.free_cells += std::popcount(b.free[w] & ~b.fill[w]);
      counts.occupied_cells += std::popcount(b.occupied[w]) + std::popcount(b.fill[w]);
    }
  }
  keys.cells = counts.free_cells + counts.occupied_cells;
  sort_buffer.clear();
  if (keys.cells == 0) return counts;  // OctoMap creates no root then
  for (std::uint32_t i = 0; i < bricks.size(); ++i) sort_buffer.push_back((bricks[i].morton << 24) | i);
  std::sort(sort_buffer.begin(), sort_buffer.end());
  counts.seconds_merge = lap();
  return counts;
}

int applyKeys(octomap::OcTree& tree, const ScanKeys& keys, int threads, std::vector<std::uint64_t>* changed_regions) {
  if (keys.cells == 0) return 0;
  return applyToTree(tree, keys.maps[0].bricks(), keys.sorted, keys.cells, std::clamp<int>(threads, 1, 64), changed_regions,
                     keys.free_discovery);
}

namespace {
void sortUnique(std::vector<std::uint64_t>& v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
}
}  // namespace

std::size_t ScanKeys::memoryUsage() const {
  std::size_t bytes = discrete_points.capacity() * sizeof(octomap::point3d) + sorted.capacity() * sizeof(std::uint64_t);
  for (const BrickMap& m : maps) bytes += m.memoryUsage();
  return bytes;
}

InsertCounts FastInserter::insert(octomap::OcTree& tree, const std::vector<octomap::point3d>& points,
                                  const octomap::point3d& origin, double max_range, bool discretize, int threads,
                                  bool pipelined, const std::vector<octomap::point3d>* surface_cells,
                                  const std::vector<octomap::point3d>* clear_rays, double free_discovery_near_range) {
  // The scan's origin (checked inside the map by the caller) and the near range in keys, capped at the map's half width.
  const auto ruleFor = [&] {
    FreeDiscoveryRule rule;
    rule.origin = tree.coordToKey(origin);
    if (free_discovery_near_range > 0.0)
      rule.near_keys = static_cast<int>(std::min(std::ceil(free_discovery_near_range / tree.getResolution()), 32768.0));
    return rule;
  };
  if (!pipelined) {
    finish();  // a pipelined update may still be running
    ScanKeys& keys = keys_[0];
    InsertCounts counts = computeKeys(tree, points, origin, max_range, discretize, threads, keys, surface_cells, clear_rays);
    keys.free_discovery = ruleFor();
    const auto started = std::chrono::steady_clock::now();
    counts.walk_threads = applyKeys(tree, keys, threads, &changed_regions_);
    counts.seconds_tree = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    boundChangedRegions();
    return counts;
  }
  // The previous scan's tree update runs on the background thread while this scan's keys are computed
  // into the other buffer (key computation never reads a node).
  ScanKeys& keys = keys_[fill_];
  InsertCounts counts = computeKeys(tree, points, origin, max_range, discretize, threads, keys, surface_cells, clear_rays);
  keys.free_discovery = ruleFor();
  const auto waited = std::chrono::steady_clock::now();
  finish();
  counts.seconds_wait = std::chrono::duration<double>(std::chrono::steady_clock::now() - waited).count();
  counts.seconds_tree = job_seconds_;
  const bool waited_for_walk = job_seconds_ > 0.0;
  job_seconds_ = 0.0;
  if (keys.cells == 0) return counts;
  // Overlapping pays only while one thread walks the tree at least as fast as all threads cast the next
  // scan's rays. When the walk is the slower stage (fine maps: many new nodes per scan), waiting for it
  // wastes a core: then walk this scan now on every thread. Decided from the previous scan, so the choice
  // follows the map as it fills; either way the scans reach the tree in order and the tree is the same.
  if (waited_for_walk) walk_is_slower_ = counts.seconds_wait > 0.2 * counts.seconds_rays;
  if (walk_is_slower_ && threads > 1) {
    const auto started = std::chrono::steady_clock::now();
    counts.walk_threads = applyKeys(tree, keys, threads, &changed_regions_);
    boundChangedRegions();
    const double walked = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    counts.seconds_tree += walked;
    // One thread would take up to `threads` times as long (the walk scales a little less than that, so this
    // leans towards staying here); back to overlapping once that is below the rays' time.
    walk_is_slower_ = walked * threads > counts.seconds_rays;
    return counts;
  }
  counts.walk_threads = 1;
  if (!worker_.joinable()) worker_ = std::thread([this] { treeThread(); });
  {
    std::lock_guard lock(mutex_);
    job_tree_ = &tree;
    job_ = &keys;
  }
  wake_.notify_one();
  fill_ ^= 1;
  return counts;
}

void FastInserter::treeThread() {
  std::unique_lock lock(mutex_);
  while (true) {
    wake_.wait(lock, [&] { return stop_ || job_ != nullptr; });
    if (job_ == nullptr) return;  // stop_ and nothing pending
    const ScanKeys* keys = job_;
    octomap::OcTree* tree = job_tree_;
    lock.unlock();
    const auto started = std::chrono::steady_clock::now();
    std::exception_ptr error;
    try {
      applyKeys(*tree, *keys, 1, &changed_regions_);  // one walk thread: the other core computes the next scan's keys
      boundChangedRegions();
    } catch (...) {
      error = std::current_exception();
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    lock.lock();
    job_seconds_ = seconds;
    job_error_ = error;
    job_ = nullptr;
    done_.notify_all();
  }
}

void FastInserter::finish() {
  if (!worker_.joinable()) return;
  std::unique_lock lock(mutex_);
  done_.wait(lock, [&] { return job_ == nullptr; });
  if (job_error_) std::rethrow_exception(std::exchange(job_error_, nullptr));
}

void FastInserter::boundChangedRegions() {
  if (changed_regions_.size() <= changed_regions_bound_) return;
  sortUnique(changed_regions_);
  // Twice what is left: a map with more regions than kMaxChangedRegions is not sorted again after every scan.
  changed_regions_bound_ = std::max(kMaxChangedRegions, 2 * changed_regions_.size());
}

std::vector<std::uint64_t> FastInserter::takeChangedRegions() {
  finish();
  sortUnique(changed_regions_);
  return std::exchange(changed_regions_, {});
}

FastInserter::~FastInserter() {
  if (!worker_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  worker_.join();  // a pending update is applied first (the tree outlives the inserter)
}

std::size_t FastInserter::memoryUsage() const { return keys_[0].memoryUsage() + keys_[1].memoryUsage(); }

void FastInserter::releaseScratch() {
  finish();
  for (ScanKeys& k : keys_) k = ScanKeys{};
}

}  // namespace ddsnav::mapper::detail
