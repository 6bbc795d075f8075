// makeBlockedCellsWorld: a world with a set of extra blocked squares (occludedSurfaceContinuation's cells).
#include "ddsnav/planner/collision_world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

namespace ddsnav::planner {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kCellsPerBucket = 16;  // a bucket is 16 x 16 cells: a line of cells puts a few dozen in one

class BlockedCellsWorld final : public CollisionWorld {
 public:
  BlockedCellsWorld(std::shared_ptr<const CollisionWorld> base, const std::vector<Vec3>& cells, double cell_size)
      : base_(std::move(base)), half_(0.5 * cell_size), bucket_size_(kCellsPerBucket * cell_size) {
    for (const Vec3& c : cells) {
      auto [it, added] = buckets_.try_emplace(key(bucketOf(c.x()), bucketOf(c.y())));
      if (added) it->second.ordinal = static_cast<int>(buckets_.size());
      it->second.centres.emplace_back(c.x(), c.y());
    }
  }

  int dimensions() const override { return base_->dimensions(); }
  Vec3 boundsMin() const override { return base_->boundsMin(); }
  Vec3 boundsMax() const override { return base_->boundsMax(); }
  double robotRadius() const override { return base_->robotRadius(); }

  bool isFree(const Vec3& p) const override {
    countCheck();
    return base_->isFree(p) && !(nearestBlocked(p, base_->robotRadius()) <= base_->robotRadius());
  }

  double clearance(const Vec3& p) const override {
    const double base = base_->clearance(p);
    if (!p.allFinite()) return base;
    const double r = base_->robotRadius();
    // Only a blocked square nearer than the base's nearest surface can lower it (and none beyond 1 km is looked for).
    const double d = nearestBlocked(p, std::isfinite(base) ? base + r : 1000.0);
    return std::min(base, d - r);
  }

  std::vector<NearbyObstacle> obstaclesNear(const Vec3& p, double range) const override {
    return withSquares(base_->obstaclesNear(p, range), p, range);
  }
  std::vector<NearbyObstacle> nearestPerBrick(const Vec3& p, double range) const override {
    return withSquares(base_->nearestPerBrick(p, range), p, range);
  }

 private:
  // The base's list with the nearest square of each bucket within range added, nearest first.
  std::vector<NearbyObstacle> withSquares(std::vector<NearbyObstacle> out, const Vec3& p, double range) const {
    if (!p.allFinite() || !(range >= 0.0)) return out;
    // The nearest square of each bucket within range, with ids of their own (negative: the base's are not).
    forBucketsWithin(p, std::min(range, 1e6), [&](const Bucket& b) {
      double best = kInf;
      Vec3 best_point = p;
      for (const auto& c : b.centres) {
        const Vec3 q = nearestPointOfSquare(c, p);
        const double d = (q - p).norm();
        if (d < best) best = d, best_point = q;
      }
      if (best <= range) out.push_back({-b.ordinal, best_point, best});
    });
    std::stable_sort(out.begin(), out.end(), [](const NearbyObstacle& a, const NearbyObstacle& b) { return a.distance < b.distance; });
    return out;
  }

  struct Bucket {
    int ordinal = 0;
    std::vector<Eigen::Vector2d> centres;
  };

  std::int64_t bucketOf(double v) const { return static_cast<std::int64_t>(std::floor(std::clamp(v / bucket_size_, -1e9, 1e9))); }
  static std::uint64_t key(std::int64_t bx, std::int64_t by) {
    return (static_cast<std::uint64_t>(bx + (std::int64_t(1) << 31)) << 32) ^ static_cast<std::uint64_t>(by + (std::int64_t(1) << 31));
  }

  Vec3 nearestPointOfSquare(const Eigen::Vector2d& c, const Vec3& p) const {
    return {std::clamp(p.x(), c.x() - half_, c.x() + half_), std::clamp(p.y(), c.y() - half_, c.y() + half_), p.z()};
  }

  template <class Fn>
  void forBucketsWithin(const Vec3& p, double reach, Fn&& fn) const {
    if (buckets_.empty()) return;
    const std::int64_t x0 = bucketOf(p.x() - reach - half_), x1 = bucketOf(p.x() + reach + half_);
    const std::int64_t y0 = bucketOf(p.y() - reach - half_), y1 = bucketOf(p.y() + reach + half_);
    // A wide reach looks at every bucket instead of every grid position in it.
    if (double(x1 - x0 + 1) * double(y1 - y0 + 1) > double(buckets_.size())) {
      for (const auto& [k, b] : buckets_) fn(b);
      return;
    }
    for (std::int64_t by = y0; by <= y1; ++by)
      for (std::int64_t bx = x0; bx <= x1; ++bx)
        if (auto it = buckets_.find(key(bx, by)); it != buckets_.end()) fn(it->second);
  }

  // Distance from p (in the plane) to the nearest blocked square within `reach`; infinity when none is.
  double nearestBlocked(const Vec3& p, double reach) const {
    double best = kInf;
    if (!p.allFinite()) return best;
    forBucketsWithin(p, reach, [&](const Bucket& b) {
      for (const auto& c : b.centres) best = std::min(best, (nearestPointOfSquare(c, p) - p).head<2>().norm());
    });
    return best;
  }

  std::shared_ptr<const CollisionWorld> base_;
  double half_, bucket_size_;
  std::unordered_map<std::uint64_t, Bucket> buckets_;
};

}  // namespace

std::unique_ptr<CollisionWorld> makeBlockedCellsWorld(std::shared_ptr<const CollisionWorld> base, std::vector<Vec3> cells,
                                                      double cell_size) {
  if (!base) throw std::invalid_argument("makeBlockedCellsWorld: no base world");
  if (!(cell_size > 0.0 && cell_size <= 1e3)) throw std::invalid_argument("makeBlockedCellsWorld: cell_size must be in (0, 1000] m");
  for (const Vec3& c : cells)
    if (!c.allFinite()) throw std::invalid_argument("makeBlockedCellsWorld: a cell centre is not finite");
  return std::make_unique<BlockedCellsWorld>(std::move(base), cells, cell_size);
}

}  // namespace ddsnav::planner
