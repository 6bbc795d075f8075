#pragma once
// Nearest-neighbour index over tree positions (2-D or 3-D) with incremental insertion: nanoflann's
// dynamic k-d tree (a logarithmic set of static trees, rebuilt in powers of two), so insertion is
// amortised O(log^2 n) and queries O(log^2 n). Every planner uses it; none scans its nodes linearly.
//
// Results are exact and fully ordered: by distance, then by index (insertion order). So equally near
// points (planners do add nodes at one position) come out the same whatever the sub-trees' layout, and
// the results equal a brute-force sort.
//
// Not thread-safe: query buffers are reused so the planners' inner loops do not allocate.

#include "ddsnav/planner/scenario.hpp"

// nanoflann 1.4's dynamic index copies a partly initialised bounding box when it creates its sub-trees;
// GCC flags that copy (harmless: the box is computed before it is read).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <nanoflann.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ddsnav::planner {

class NearestIndex {
 public:
  explicit NearestIndex(int dimensions) : dims_(dimensions), cloud_(std::make_unique<Cloud>()) {
    if (dims_ != 2 && dims_ != 3) throw std::invalid_argument("NearestIndex: dimensions must be 2 or 3");
    if (dims_ == 2) tree2_ = std::make_unique<Tree<2>>(2, *cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(8), kMaxPoints);
    else tree3_ = std::make_unique<Tree<3>>(3, *cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(8), kMaxPoints);
  }

  int dimensions() const { return dims_; }
  std::size_t size() const { return cloud_->points.size(); }
  bool empty() const { return cloud_->points.empty(); }
  Vec3 point(int i) const {
    const auto& p = cloud_->points[static_cast<std::size_t>(i)];
    return Vec3(p[0], p[1], p[2]);
  }

  // Adds a position; returns its index (0, 1, 2, ... in insertion order).
  int add(const Vec3& p) {
    const auto index = static_cast<std::uint32_t>(cloud_->points.size());
    cloud_->points.push_back({p.x(), p.y(), dims_ == 3 ? p.z() : 0.0});
    if (tree2_) tree2_->addPoints(index, index);
    else tree3_->addPoints(index, index);
    return static_cast<int>(index);
  }

  // Index of the nearest stored position (the smallest index among equally near ones), -1 when empty.
  int nearest(const Vec3& q) const {
    if (empty()) return -1;
    std::uint32_t index = 0;
    double dist2 = 0.0;
    OrderedKnn result(1, &index, &dist2);
    search(result, q);
    return static_cast<int>(index);
  }

  // The k nearest, nearest first, ties by index (fewer when the index holds fewer).
  void kNearest(const Vec3& q, std::size_t k, std::vector<int>& out) const {
    out.clear();
    k = std::min(k, size());
    if (k == 0) return;
    knn_index_.resize(k);
    knn_dist_.resize(k);
    OrderedKnn result(k, knn_index_.data(), knn_dist_.data());
    search(result, q);
    for (std::size_t i = 0; i < result.size(); ++i) out.push_back(static_cast<int>(knn_index_[i]));
  }

  // Every position strictly within distance r, nearest first, ties by index.
  void withinRadius(const Vec3& q, double r, std::vector<int>& out) const {
    out.clear();
    if (empty() || !(r > 0.0)) return;
    nanoflann::RadiusResultSet<double, std::uint32_t> result(r * r, radius_hits_);
    search(result, q);
    sortHits(radius_hits_);
    for (const auto& hit : radius_hits_) out.push_back(static_cast<int>(hit.first));
  }

 private:
  static constexpr std::size_t kMaxPoints = std::size_t{1} << 26;

  // k-nearest result set for nanoflann ordered by (distance, index). nanoflann only offers a leaf point
  // when it is strictly nearer than worstDist(), so once full this reports the next double above the
  // current k-th distance: a point tied with it is still offered, and the smaller index wins.
  class OrderedKnn {
   public:
    using DistanceType = double;
    using IndexType = std::uint32_t;
    OrderedKnn(std::size_t capacity, std::uint32_t* indices, double* dists)
        : capacity_(capacity), indices_(indices), dists_(dists) {}
    std::size_t size() const { return count_; }
    bool full() const { return count_ == capacity_; }
    double worstDist() const { return worst_; }
    bool addPoint(double dist, std::uint32_t index) {
      std::size_t i = count_;
      // Shift every entry ordered after (dist, index) one place back; the last one falls off when full.
      while (i > 0 && (dists_[i - 1] > dist || (dists_[i - 1] == dist && indices_[i - 1] > index))) {
        if (i < capacity_) {
          dists_[i] = dists_[i - 1];
          indices_[i] = indices_[i - 1];
        }
        --i;
      }
      if (i < capacity_) {
        dists_[i] = dist;
        indices_[i] = index;
        if (count_ < capacity_) ++count_;
        if (full()) worst_ = nextUp(dists_[capacity_ - 1]);
      }
      return true;  // keep searching
    }

   private:
    // std::nextafter(d, +inf): for a finite positive double one ulp up is its bit pattern plus one (the
    // library call was ~2 % of a planner's time); zero, inf and NaN take the library's way.
    static double nextUp(double d) {
      if (d > 0.0 && d < std::numeric_limits<double>::max()) return std::bit_cast<double>(std::bit_cast<std::uint64_t>(d) + 1);
      return std::nextafter(d, std::numeric_limits<double>::infinity());
    }
    std::size_t capacity_;
    std::size_t count_ = 0;
    double worst_ = std::numeric_limits<double>::max();  // what worstDist() reports, kept current by addPoint
    std::uint32_t* indices_;
    double* dists_;
  };

  // Radius hits ordered by (distance, index). Most sets are small (a rewiring neighbourhood): an
  // insertion sort beats std::sort's set-up there.
  static void sortHits(std::vector<std::pair<std::uint32_t, double>>& hits) {
    const auto before = [](const auto& a, const auto& b) {
      return a.second != b.second ? a.second < b.second : a.first < b.first;
    };
    if (hits.size() > 32) {
      std::sort(hits.begin(), hits.end(), before);
      return;
    }
    for (std::size_t i = 1; i < hits.size(); ++i) {
      const auto hit = hits[i];
      std::size_t j = i;
      for (; j > 0 && before(hit, hits[j - 1]); --j) hits[j] = hits[j - 1];
      hits[j] = hit;
    }
  }

  struct Cloud {
    std::vector<std::array<double, 3>> points;
    std::size_t kdtree_get_point_count() const { return points.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t d) const { return points[i][d]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const { return false; }
  };
  template <int D>
  using Tree = nanoflann::KDTreeSingleIndexDynamicAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, D,
                                                          std::uint32_t>;

  template <class Result>
  void search(Result& result, const Vec3& q) const {
    const double query[3] = {q.x(), q.y(), dims_ == 3 ? q.z() : 0.0};
    if (tree2_) tree2_->findNeighbors(result, query, nanoflann::SearchParams());
    else tree3_->findNeighbors(result, query, nanoflann::SearchParams());
  }

  int dims_;
  std::unique_ptr<Cloud> cloud_;  // on the heap: the trees keep a reference, so moves stay safe
  std::unique_ptr<Tree<2>> tree2_;
  std::unique_ptr<Tree<3>> tree3_;
  mutable std::vector<std::uint32_t> knn_index_;
  mutable std::vector<double> knn_dist_;
  mutable std::vector<std::pair<std::uint32_t, double>> radius_hits_;
};

}  // namespace ddsnav::planner

#pragma GCC diagnostic pop
