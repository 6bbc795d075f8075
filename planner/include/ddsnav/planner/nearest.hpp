#pragma once
// Nearest-neighbour index over tree positions (2-D or 3-D) with incremental insertion: one bucket k-d
// tree grown in place. Leaves hold up to kBucket points; a leaf that overflows is split at the median of
// its widest-spread axis. Every node keeps the tight bounding box of the points below it, and queries
// prune whole subtrees by box distance, so no query scans the nodes linearly.
//
// Planners insert spatially correlated points (trees grow outward from the start), which would turn a
// plain incremental k-d tree into a long vine. So, as in a scapegoat tree, a subtree whose larger child
// holds more than kBalance of its points is rebuilt balanced (median splits) on the insertion that
// unbalances it: the depth stays O(log n) and insertion is amortised O(log^2 n) in the worst case.
//
// Query contract (callers rely on it): exact results; kNearest and withinRadius order by distance, then
// by index; nearest returns the smallest index among equally near points; withinRadius is strict (< r).
//
// Not thread-safe: query buffers are reused so the planners' inner loops do not allocate.

#include "ddsnav/planner/scenario.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ddsnav::planner {
namespace detail {

template <int D>
class BucketKdTree {
 public:
  using Point = std::array<double, D>;

  static constexpr int kBucket = 16;           // points per leaf slab
  static constexpr double kBalance = 0.75;     // a child above this share of its parent's points triggers a rebuild
  static constexpr std::uint32_t kMinRebuild = 4 * kBucket;  // smaller subtrees are shallow anyway
  static constexpr std::size_t kSortedKnnMax = 32;            // larger k keeps its candidates in a heap

  std::size_t size() const { return points_.size(); }
  const Point& point(std::size_t i) const { return points_[i]; }

  void add(const Point& p) {
    const auto id = static_cast<std::uint32_t>(points_.size());
    points_.push_back(p);
    if (root_ < 0) {
      root_ = newNode();
      nodes_[root_].lo = p;
      nodes_[root_].hi = p;
    }
    // Walk down to the leaf, growing boxes and counts on the way.
    path_.clear();
    int n = root_;
    while (true) {
      Node& node = nodes_[n];
      for (int d = 0; d < D; ++d) {
        node.lo[d] = std::min(node.lo[d], p[d]);
        node.hi[d] = std::max(node.hi[d], p[d]);
      }
      ++node.count;
      path_.push_back(n);
      if (node.isLeaf()) break;
      n = node.child[p[node.split_dim] < node.split ? 0 : 1];
    }
    const int head = nodes_[n].slab;
    if (head >= 0 && slabs_[head].count == kBucket) {
      rebuild(n, id);  // the leaf is full: split it (median of its widest axis)
    } else {
      leafAppend(n, id);
    }
    // Rebuild the highest subtree on the path that this insertion left unbalanced.
    for (std::size_t i = 0; i + 1 < path_.size(); ++i) {
      const Node& node = nodes_[path_[i]];
      if (node.count < kMinRebuild) break;
      const auto larger = std::max(nodes_[node.child[0]].count, nodes_[node.child[1]].count);
      if (static_cast<double>(larger) > kBalance * node.count) {
        rebuild(path_[i], -1);
        break;
      }
    }
  }

  // Smallest index among the nearest points; -1 when empty.
  int nearest(const Point& q) const {
    if (root_ < 0) return -1;
    best_d2_ = std::numeric_limits<double>::infinity();
    best_id_ = std::numeric_limits<std::uint32_t>::max();
    nearestIn(root_, q);
    return static_cast<int>(best_id_);
  }

  // The k nearest, by (distance, index).
  void kNearest(const Point& q, std::size_t k, std::vector<int>& out) const {
    out.clear();
    k = std::min(k, size());
    if (k == 0) return;
    knn_.clear();
    knn_.reserve(k);
    knn_capacity_ = k;
    if (k <= kSortedKnnMax) {
      kNearestIn<true>(root_, q);
    } else {
      kNearestIn<false>(root_, q);
      std::sort_heap(knn_.begin(), knn_.end());
    }
    for (const auto& hit : knn_) out.push_back(static_cast<int>(hit.id));
  }

  // Every point strictly within sqrt(r2), by (distance, index).
  void withinRadius(const Point& q, double r2, std::vector<int>& out) const {
    out.clear();
    if (root_ < 0) return;
    hit_count_ = 0;
    radius_r2_ = r2;
    withinRadiusIn(root_, q);
    const RadiusKey* const sorted = sortHits();
    for (std::size_t i = 0; i < hit_count_; ++i) out.push_back(static_cast<int>(static_cast<std::uint32_t>(sorted[i])));
  }

  // Longest root-to-leaf path (1 for a single leaf, 0 when empty): a diagnostic for tests and benchmarks.
  int depth() const { return root_ < 0 ? 0 : depthOf(root_); }

 private:
  struct Node {
    Point lo{}, hi{};             // tight box of the points below
    std::uint32_t count = 0;      // points below
    int child[2] = {-1, -1};      // both -1 for a leaf
    int split_dim = 0;
    double split = 0.0;           // points with p[split_dim] < split go to child[0]
    int slab = -1;                // leaf: first slab of its chain (-1 when it holds none yet)
    bool isLeaf() const { return child[0] < 0; }
  };
  // A leaf's points, coordinates stored axis by axis so the distance loop vectorises. A leaf normally
  // has one slab; it chains more only when it holds more than kBucket identical points (no axis to split).
  struct Slab {
    double coord[D][kBucket]{};
    std::uint32_t id[kBucket]{};
    int count = 0;
    int next = -1;
  };
  struct Hit {
    double d2;
    std::uint32_t id;
    bool operator<(const Hit& o) const { return d2 != o.d2 ? d2 < o.d2 : id < o.id; }
  };
  // A radius hit as one integer whose order is (distance, index): the bits of a non-negative double
  // order like its value, so (bits(d2) << 32 | id) compares without branches. Radius queries in RRT*-like
  // planners return tens to hundreds of points, and sorting these keys is measurably faster than
  // sorting Hit with its two-field comparison.
  __extension__ typedef unsigned __int128 RadiusKey;
  static RadiusKey radiusKey(double d2, std::uint32_t id) {
    return (static_cast<RadiusKey>(std::bit_cast<std::uint64_t>(d2)) << 32) | id;
  }

  static double boxDistance2(const Node& node, const Point& q) {
    double s = 0.0;
    for (int d = 0; d < D; ++d) {
      const double t = q[d] < node.lo[d] ? node.lo[d] - q[d] : (q[d] > node.hi[d] ? q[d] - node.hi[d] : 0.0);
      s += t * t;
    }
    return s;
  }
  // Squared distances from q to every slot of a slab (slots past count hold zeros and are ignored).
  static void slabDistances2(const Slab& slab, const Point& q, double (&d2)[kBucket]) {
    for (int j = 0; j < kBucket; ++j) {
      const double t = slab.coord[0][j] - q[0];
      d2[j] = t * t;
    }
    for (int d = 1; d < D; ++d) {
      for (int j = 0; j < kBucket; ++j) {
        const double t = slab.coord[d][j] - q[d];
        d2[j] += t * t;
      }
    }
  }

  // Visits the nearer child first; a child is skipped when its box is farther than the current bound
  // (an equally far box is still visited: it may hold a tie with a smaller index).
  template <class Leaf, class Bound>
  void descend(int n, const Point& q, Leaf&& leaf, Bound&& bound) const {
    const Node& node = nodes_[n];
    if (node.isLeaf()) {
      leaf(node);
      return;
    }
    int first = node.child[0], second = node.child[1];
    double d_first = boxDistance2(nodes_[first], q), d_second = boxDistance2(nodes_[second], q);
    if (d_second < d_first) {
      std::swap(first, second);
      std::swap(d_first, d_second);
    }
    if (d_first <= bound()) descend(first, q, leaf, bound);
    if (d_second <= bound()) descend(second, q, leaf, bound);
  }

  void nearestIn(int n, const Point& q) const {
    descend(
        n, q,
        [&](const Node& node) {
          double d2[kBucket];
          for (int s = node.slab; s >= 0; s = slabs_[s].next) {
            const Slab& slab = slabs_[s];
            slabDistances2(slab, q, d2);
            for (int j = 0; j < slab.count; ++j) {
              if (d2[j] < best_d2_ || (d2[j] == best_d2_ && slab.id[j] < best_id_)) {
                best_d2_ = d2[j];
                best_id_ = slab.id[j];
              }
            }
          }
        },
        [&] { return best_d2_; });
  }

  // The k best so far: a sorted array for small k (a few shifts per accepted point), a max-heap for
  // large k (where shifting would be quadratic). Either way knn_ holds the worst kept hit at back()
  // (sorted) or front() (heap).
  template <bool kSorted>
  void kNearestIn(int n, const Point& q) const {
    const auto worst = [&]() -> const Hit& { return kSorted ? knn_.back() : knn_.front(); };
    const auto bound = [&] {
      return knn_.size() < knn_capacity_ ? std::numeric_limits<double>::infinity() : worst().d2;
    };
    descend(
        n, q,
        [&](const Node& node) {
          double d2[kBucket];
          for (int s = node.slab; s >= 0; s = slabs_[s].next) {
            const Slab& slab = slabs_[s];
            slabDistances2(slab, q, d2);
            for (int j = 0; j < slab.count; ++j) {
              const Hit hit{d2[j], slab.id[j]};
              const bool full = knn_.size() == knn_capacity_;
              if (full && !(hit < worst())) continue;
              if constexpr (kSorted) {
                if (full) knn_.pop_back();
                knn_.push_back(hit);
                for (std::size_t i = knn_.size() - 1; i > 0 && hit < knn_[i - 1]; --i) std::swap(knn_[i], knn_[i - 1]);
              } else {
                if (full) {
                  std::pop_heap(knn_.begin(), knn_.end());
                  knn_.pop_back();
                }
                knn_.push_back(hit);
                std::push_heap(knn_.begin(), knn_.end());
              }
            }
          }
        },
        bound);
  }

  void withinRadiusIn(int n, const Point& q) const {
    const Node& node = nodes_[n];
    if (node.isLeaf()) {
      double d2[kBucket];
      for (int s = node.slab; s >= 0; s = slabs_[s].next) {
        const Slab& slab = slabs_[s];
        slabDistances2(slab, q, d2);
        // Branch-free append: every point is written, only those inside advance the count (about as
        // many points fall outside as inside, so a branch here would mispredict often).
        if (hits_.size() < hit_count_ + kBucket) hits_.resize(2 * (hit_count_ + kBucket));
        RadiusKey* out = hits_.data();
        for (int j = 0; j < slab.count; ++j) {
          out[hit_count_] = radiusKey(d2[j], slab.id[j]);
          hit_count_ += d2[j] < radius_r2_ ? 1 : 0;
        }
      }
      return;
    }
    for (const int c : node.child) {
      if (boxDistance2(nodes_[c], q) < radius_r2_) withinRadiusIn(c, q);
    }
  }

  static void insertionSort(RadiusKey* first, RadiusKey* last) {
    for (RadiusKey* i = first + (first != last); i < last; ++i) {
      const RadiusKey h = *i;
      RadiusKey* j = i;
      for (; j > first && h < *(j - 1); --j) *j = *(j - 1);
      *j = h;
    }
  }

  // Sorts the radius hits; returns where the sorted keys are (hits_ or bucket_keys_). Short lists are
  // insertion sorted. Longer ones (GART's rewiring radius returns ~30-300 points) are distributed into
  // hit_count_ buckets by d2 / r2 first: for locally even points d2 is spread evenly over [0, r2) in
  // 2-D (skewed towards r2 in 3-D; mapping by d2^1.5 there measured no faster), so the buckets hold one
  // or two keys each and sorting becomes about linear; a crowded bucket (many equal distances) falls
  // back to std::sort. Bucket numbers never decrease with d2, so the result is exactly the
  // (distance, index) order.
  const RadiusKey* sortHits() const {
    RadiusKey* const first = hits_.data();
    const std::size_t n = hit_count_;
    const double scale = static_cast<double>(n) / radius_r2_;
    if (n <= 24 || !std::isfinite(scale) || !(scale > 0.0)) {
      if (n <= 24) insertionSort(first, first + n);
      else std::sort(first, first + n);
      return first;
    }
    const auto bucketOf = [&](RadiusKey key) {
      const double d2 = std::bit_cast<double>(static_cast<std::uint64_t>(key >> 32));
      return std::min(n - 1, static_cast<std::size_t>(d2 * scale));
    };
    bucket_start_.assign(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i) ++bucket_start_[bucketOf(first[i]) + 1];
    for (std::size_t b = 0; b < n; ++b) bucket_start_[b + 1] += bucket_start_[b];
    if (bucket_keys_.size() < n) bucket_keys_.resize(n);
    for (std::size_t i = 0; i < n; ++i) bucket_keys_[bucket_start_[bucketOf(first[i])]++] = first[i];
    // bucket_start_[b] now holds the end of bucket b (and the start of b + 1).
    RadiusKey* const sorted = bucket_keys_.data();
    std::size_t begin = 0;
    for (std::size_t b = 0; b < n; ++b) {
      const std::size_t end = bucket_start_[b];
      if (end - begin > 16) std::sort(sorted + begin, sorted + end);
      else if (end - begin > 1) insertionSort(sorted + begin, sorted + end);
      begin = end;
    }
    return sorted;
  }

  int newNode() {
    if (!free_nodes_.empty()) {
      const int n = free_nodes_.back();
      free_nodes_.pop_back();
      nodes_[n] = Node{};
      return n;
    }
    nodes_.emplace_back();
    return static_cast<int>(nodes_.size()) - 1;
  }
  int newSlab() {
    if (!free_slabs_.empty()) {
      const int s = free_slabs_.back();
      free_slabs_.pop_back();
      slabs_[s] = Slab{};
      return s;
    }
    slabs_.emplace_back();
    return static_cast<int>(slabs_.size()) - 1;
  }

  void leafAppend(int n, std::uint32_t id) {
    int s = nodes_[n].slab;
    if (s < 0 || slabs_[s].count == kBucket) {
      const int fresh = newSlab();
      slabs_[fresh].next = s;
      nodes_[n].slab = fresh;
      s = fresh;
    }
    Slab& slab = slabs_[s];
    for (int d = 0; d < D; ++d) slab.coord[d][slab.count] = points_[id][d];
    slab.id[slab.count] = id;
    ++slab.count;
  }

  // Collects the indices below node n into build_ids_, freeing its descendants and slabs (n itself stays).
  void collect(int n) {
    Node& node = nodes_[n];
    if (node.isLeaf()) {
      for (int s = node.slab; s >= 0;) {
        const Slab& slab = slabs_[s];
        build_ids_.insert(build_ids_.end(), slab.id, slab.id + slab.count);
        free_slabs_.push_back(s);
        s = slab.next;
      }
      node.slab = -1;
      return;
    }
    for (const int c : node.child) {
      collect(c);
      free_nodes_.push_back(c);
    }
  }

  // Rebuilds the subtree at n balanced from the points below it (plus `extra` when >= 0).
  void rebuild(int n, std::int64_t extra) {
    build_ids_.clear();
    collect(n);
    if (extra >= 0) build_ids_.push_back(static_cast<std::uint32_t>(extra));
    build(n, 0, build_ids_.size());
  }

  void build(int n, std::size_t begin, std::size_t end) {
    Node box;
    box.lo = box.hi = points_[build_ids_[begin]];
    for (std::size_t i = begin + 1; i < end; ++i) {
      const Point& p = points_[build_ids_[i]];
      for (int d = 0; d < D; ++d) {
        box.lo[d] = std::min(box.lo[d], p[d]);
        box.hi[d] = std::max(box.hi[d], p[d]);
      }
    }
    int dim = 0;
    for (int d = 1; d < D; ++d) {
      if (box.hi[d] - box.lo[d] > box.hi[dim] - box.lo[dim]) dim = d;
    }
    box.count = static_cast<std::uint32_t>(end - begin);
    nodes_[n] = box;
    if (end - begin <= static_cast<std::size_t>(kBucket) || !(box.hi[dim] > box.lo[dim])) {
      for (std::size_t i = begin; i < end; ++i) leafAppend(n, build_ids_[i]);
      return;
    }
    // Median split, then move points equal to the median so that "left iff p[dim] < split" holds exactly.
    const auto value = [&](std::uint32_t id) { return points_[id][dim]; };
    const auto first = build_ids_.begin() + static_cast<std::ptrdiff_t>(begin);
    const auto last = build_ids_.begin() + static_cast<std::ptrdiff_t>(end);
    const auto mid = first + static_cast<std::ptrdiff_t>((end - begin) / 2);
    std::nth_element(first, mid, last, [&](std::uint32_t a, std::uint32_t b) { return value(a) < value(b); });
    double split = value(*mid);
    auto cut = std::partition(first, mid, [&](std::uint32_t id) { return value(id) < split; });
    if (cut == first) {
      // The median is the minimum: split just above it instead (the axis has spread, so a larger value exists).
      cut = std::partition(first, last, [&](std::uint32_t id) { return value(id) <= split; });
      double above = std::numeric_limits<double>::infinity();
      for (auto it = cut; it != last; ++it) above = std::min(above, value(*it));
      split = above;
    }
    const int left = newNode();
    const int right = newNode();
    Node& node = nodes_[n];
    node.child[0] = left;
    node.child[1] = right;
    node.split_dim = dim;
    node.split = split;
    const auto middle = static_cast<std::size_t>(cut - build_ids_.begin());
    build(left, begin, middle);
    build(right, middle, end);
  }

  int depthOf(int n) const {
    const Node& node = nodes_[n];
    if (node.isLeaf()) return 1;
    return 1 + std::max(depthOf(node.child[0]), depthOf(node.child[1]));
  }

  std::vector<Point> points_;  // by index (insertion order)
  std::vector<Node> nodes_;
  std::vector<Slab> slabs_;
  std::vector<int> free_nodes_, free_slabs_;
  int root_ = -1;
  std::vector<int> path_;                 // reused by add
  std::vector<std::uint32_t> build_ids_;  // reused by rebuild
  // Query state, reused so queries do not allocate.
  mutable double best_d2_ = 0.0;
  mutable std::uint32_t best_id_ = 0;
  mutable std::vector<Hit> knn_;
  mutable std::size_t knn_capacity_ = 0;
  mutable std::vector<RadiusKey> hits_;  // radius hits in [0, hit_count_); grown, never shrunk
  mutable std::vector<RadiusKey> bucket_keys_;       // the hits distributed by distance (sortHits)
  mutable std::vector<std::size_t> bucket_start_;   // bucket boundaries (sortHits)
  mutable std::size_t hit_count_ = 0;
  mutable double radius_r2_ = 0.0;
};

}  // namespace detail

class NearestIndex {
 public:
  explicit NearestIndex(int dimensions) : dims_(dimensions) {
    if (dims_ != 2 && dims_ != 3) throw std::invalid_argument("NearestIndex: dimensions must be 2 or 3");
  }

  int dimensions() const { return dims_; }
  std::size_t size() const { return dims_ == 2 ? tree2_.size() : tree3_.size(); }
  bool empty() const { return size() == 0; }
  Vec3 point(int i) const {
    const auto k = static_cast<std::size_t>(i);
    if (dims_ == 2) return Vec3(tree2_.point(k)[0], tree2_.point(k)[1], 0.0);
    const auto& p = tree3_.point(k);
    return Vec3(p[0], p[1], p[2]);
  }

  // Adds a position; returns its index (0, 1, 2, ... in insertion order). In 2-D, z is ignored.
  int add(const Vec3& p) {
    const int index = static_cast<int>(size());
    if (dims_ == 2) tree2_.add({p.x(), p.y()});
    else tree3_.add({p.x(), p.y(), p.z()});
    return index;
  }

  // Index of the nearest stored position (the smallest index among equally near ones), -1 when empty.
  int nearest(const Vec3& q) const {
    return dims_ == 2 ? tree2_.nearest({q.x(), q.y()}) : tree3_.nearest({q.x(), q.y(), q.z()});
  }

  // The k nearest, nearest first, ties by index (fewer when the index holds fewer).
  void kNearest(const Vec3& q, std::size_t k, std::vector<int>& out) const {
    if (dims_ == 2) tree2_.kNearest({q.x(), q.y()}, k, out);
    else tree3_.kNearest({q.x(), q.y(), q.z()}, k, out);
  }

  // Every position strictly within distance r, nearest first (ties by index, so results are deterministic).
  void withinRadius(const Vec3& q, double r, std::vector<int>& out) const {
    out.clear();
    if (!(r > 0.0)) return;
    if (dims_ == 2) tree2_.withinRadius({q.x(), q.y()}, r * r, out);
    else tree3_.withinRadius({q.x(), q.y(), q.z()}, r * r, out);
  }

  // Depth of the k-d tree (diagnostic for tests and benchmarks; 0 when empty).
  int depth() const { return dims_ == 2 ? tree2_.depth() : tree3_.depth(); }

 private:
  int dims_;
  detail::BucketKdTree<2> tree2_;
  detail::BucketKdTree<3> tree3_;
};

}  // namespace ddsnav::planner
