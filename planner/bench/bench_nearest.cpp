// ddsnav-bench-nearest: the planners' NearestIndex (one incremental bucket k-d tree) against the
// nanoflann dynamic index it replaced (kept here, only for this comparison), in the same run.
//
// For each dimension (2, 3), size n and insertion order it times, per operation:
//   insert  - adding n points one by one;
//   nearest - exact nearest of random queries in the bounds;
//   knn10   - the 10 nearest;
//   radiusN - every point within r, r chosen so that about N uniform points fall inside (N = 20 is
//             typical of RRT*, 100 of GART's rewiring radius on the benchmark scenarios);
//   grow    - an RRT-like loop: nearest of a random target, then add a point one step towards it
//             (the insertion order the planners really produce: correlated, the tree growing outward).
// Every result of the two indices is compared; the run fails (exit 1) on any difference.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <nanoflann.hpp>
#pragma GCC diagnostic pop

#include "ddsnav/planner/nearest.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace {

using ddsnav::planner::NearestIndex;
using ddsnav::planner::Vec3;

// The previous NearestIndex: nanoflann's KDTreeSingleIndexDynamicAdaptor (a logarithmic set of static
// trees), same interface and same result order.
class NanoflannIndex {
 public:
  explicit NanoflannIndex(int dimensions) : dims_(dimensions), cloud_(std::make_unique<Cloud>()) {
    if (dims_ == 2) tree2_ = std::make_unique<Tree<2>>(2, *cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(8), kMaxPoints);
    else tree3_ = std::make_unique<Tree<3>>(3, *cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(8), kMaxPoints);
  }
  std::size_t size() const { return cloud_->points.size(); }
  int add(const Vec3& p) {
    const auto index = static_cast<std::uint32_t>(cloud_->points.size());
    cloud_->points.push_back({p.x(), p.y(), dims_ == 3 ? p.z() : 0.0});
    if (tree2_) tree2_->addPoints(index, index);
    else tree3_->addPoints(index, index);
    return static_cast<int>(index);
  }
  Vec3 point(int i) const {
    const auto& p = cloud_->points[static_cast<std::size_t>(i)];
    return Vec3(p[0], p[1], p[2]);
  }
  int nearest(const Vec3& q) const {
    if (size() == 0) return -1;
    std::uint32_t index = 0;
    double dist2 = 0.0;
    nanoflann::KNNResultSet<double, std::uint32_t> result(1);
    result.init(&index, &dist2);
    search(result, q);
    return static_cast<int>(index);
  }
  void kNearest(const Vec3& q, std::size_t k, std::vector<int>& out) const {
    out.clear();
    k = std::min(k, size());
    if (k == 0) return;
    knn_index_.resize(k);
    knn_dist_.resize(k);
    nanoflann::KNNResultSet<double, std::uint32_t> result(k);
    result.init(knn_index_.data(), knn_dist_.data());
    search(result, q);
    for (std::size_t i = 0; i < result.size(); ++i) out.push_back(static_cast<int>(knn_index_[i]));
  }
  void withinRadius(const Vec3& q, double r, std::vector<int>& out) const {
    out.clear();
    if (size() == 0 || !(r > 0.0)) return;
    nanoflann::RadiusResultSet<double, std::uint32_t> result(r * r, radius_hits_);
    search(result, q);
    std::sort(radius_hits_.begin(), radius_hits_.end(), [](const auto& a, const auto& b) {
      return a.second != b.second ? a.second < b.second : a.first < b.first;
    });
    for (const auto& hit : radius_hits_) out.push_back(static_cast<int>(hit.first));
  }

 private:
  static constexpr std::size_t kMaxPoints = std::size_t{1} << 26;
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
  std::unique_ptr<Cloud> cloud_;
  std::unique_ptr<Tree<2>> tree2_;
  std::unique_ptr<Tree<3>> tree3_;
  mutable std::vector<std::uint32_t> knn_index_;
  mutable std::vector<double> knn_dist_;
  mutable std::vector<std::pair<std::uint32_t, double>> radius_hits_;
};

constexpr double kSide = 100.0;  // points and queries in [0, kSide]^dims

Vec3 uniformPoint(std::mt19937_64& rng, int dims) {
  std::uniform_real_distribution<double> u(0.0, kSide);
  const double x = u(rng), y = u(rng);
  return Vec3(x, y, dims == 3 ? u(rng) : 0.0);
}

double seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

struct Timings {
  double insert = 0, nearest = 0, knn = 0, radius_small = 0, radius_large = 0, grow = 0;  // ns per operation
  std::uint64_t checksum = 0;  // every returned index, mixed
  double mean_hits_small = 0, mean_hits_large = 0;
};

void mix(std::uint64_t& h, std::uint64_t v) { h = (h ^ v) * 0x100000001b3ULL; }

// One pass of every workload over a fresh index of type Index.
template <class Index>
Timings measure(int dims, int n, int queries, std::uint64_t seed) {
  Timings t;
  std::mt19937_64 rng(seed);
  std::vector<Vec3> points(static_cast<std::size_t>(n)), probes(static_cast<std::size_t>(queries));
  for (auto& p : points) p = uniformPoint(rng, dims);
  for (auto& q : probes) q = uniformPoint(rng, dims);
  // The radius holding about `hits` uniform points.
  const auto radiusFor = [&](double hits) {
    return dims == 2 ? std::sqrt(hits * kSide * kSide / (M_PI * n))
                     : std::cbrt(hits * kSide * kSide * kSide / (4.0 / 3.0 * M_PI * n));
  };
  Index index(dims);
  auto start = std::chrono::steady_clock::now();
  for (const auto& p : points) index.add(p);
  t.insert = seconds(start) * 1e9 / n;

  start = std::chrono::steady_clock::now();
  for (const auto& q : probes) mix(t.checksum, static_cast<std::uint64_t>(index.nearest(q)));
  t.nearest = seconds(start) * 1e9 / queries;

  std::vector<int> out;
  start = std::chrono::steady_clock::now();
  for (const auto& q : probes) {
    index.kNearest(q, 10, out);
    for (const int i : out) mix(t.checksum, static_cast<std::uint64_t>(i));
  }
  t.knn = seconds(start) * 1e9 / queries;

  const auto radiusQueries = [&](double r, double& ns, double& mean_hits) {
    std::size_t hits = 0;
    const auto begin = std::chrono::steady_clock::now();
    for (const auto& q : probes) {
      index.withinRadius(q, r, out);
      hits += out.size();
      for (const int i : out) mix(t.checksum, static_cast<std::uint64_t>(i));
    }
    ns = seconds(begin) * 1e9 / queries;
    mean_hits = static_cast<double>(hits) / queries;
  };
  radiusQueries(radiusFor(20), t.radius_small, t.mean_hits_small);
  radiusQueries(radiusFor(100), t.radius_large, t.mean_hits_large);

  // RRT-like growth from the centre: nearest to a random target, then one step of 1 m towards it.
  Index tree(dims);
  tree.add(Vec3(kSide / 2, kSide / 2, dims == 3 ? kSide / 2 : 0.0));
  start = std::chrono::steady_clock::now();
  for (int i = 1; i < n; ++i) {
    const Vec3 target = uniformPoint(rng, dims);
    const int near = tree.nearest(target);
    mix(t.checksum, static_cast<std::uint64_t>(near));
    const Vec3 from = tree.point(near);
    const Vec3 step = target - from;
    tree.add(step.norm() > 1.0 ? Vec3(from + step.normalized()) : target);
  }
  t.grow = seconds(start) * 1e9 / (n - 1);
  return t;
}

// Median over repeats, operation by operation.
template <class Index>
Timings medianOf(int repeats, int dims, int n, int queries) {
  std::vector<Timings> runs;
  for (int i = 0; i < repeats; ++i) runs.push_back(measure<Index>(dims, n, queries, 1000 + static_cast<std::uint64_t>(n)));
  Timings m = runs.front();
  const auto median = [&](double Timings::*field) {
    std::vector<double> v;
    for (const auto& run : runs) v.push_back(run.*field);
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  m.insert = median(&Timings::insert);
  m.nearest = median(&Timings::nearest);
  m.knn = median(&Timings::knn);
  m.radius_small = median(&Timings::radius_small);
  m.radius_large = median(&Timings::radius_large);
  m.grow = median(&Timings::grow);
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"NearestIndex (bucket k-d tree) vs nanoflann's dynamic index: insert, nearest, k=10, radius, RRT-like growth"};
  std::vector<int> sizes{1000, 10000, 100000};
  int queries = 20000;
  int repeats = 3;
  app.add_option("--sizes", sizes, "numbers of points")->check(CLI::Range(2, 10000000));
  app.add_option("--queries", queries, "queries per workload")->check(CLI::Range(1, 10000000));
  app.add_option("--repeats", repeats, "repeats per cell (the median is reported)")->check(CLI::Range(1, 100));
  CLI11_PARSE(app, argc, argv);

  std::printf("ns per operation, median of %d; ratio = nanoflann / bucket k-d tree (> 1: the new index is faster)\n", repeats);
  std::printf("%-4s %-8s %-9s %10s %10s %8s\n", "dim", "n", "op", "nanoflann", "bucket-kd", "ratio");
  bool same = true;
  for (const int dims : {2, 3}) {
    for (const int n : sizes) {
      const Timings old_index = medianOf<NanoflannIndex>(repeats, dims, n, queries);
      const Timings new_index = medianOf<NearestIndex>(repeats, dims, n, queries);
      const auto row = [&](const char* op, double a, double b) {
        std::printf("%-4d %-8d %-9s %10.1f %10.1f %8.2f\n", dims, n, op, a, b, a / b);
      };
      row("insert", old_index.insert, new_index.insert);
      row("nearest", old_index.nearest, new_index.nearest);
      row("knn10", old_index.knn, new_index.knn);
      row("radius20", old_index.radius_small, new_index.radius_small);
      row("radius100", old_index.radius_large, new_index.radius_large);
      row("grow", old_index.grow, new_index.grow);
      std::printf("%-4d %-8d mean radius hits %.1f and %.1f, results %s\n", dims, n, new_index.mean_hits_small,
                  new_index.mean_hits_large,
                  old_index.checksum == new_index.checksum ? "identical" : "DIFFER");
      same = same && old_index.checksum == new_index.checksum;
    }
  }
  return same ? 0 : 1;
}
