// makeFusedWorld: the OctoMap's structure and perception's obstacle ellipsoids as one collision world.
#include "ddsnav/planner/collision_world.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_set>

namespace ddsnav::planner {

UnknownSpace parseUnknownSpace(const std::string& text) {
  if (text == "optimistic") return UnknownSpace::Optimistic;
  if (text == "conservative") return UnknownSpace::Conservative;
  throw std::invalid_argument("unknown space policy: expected optimistic or conservative, got '" + text + "'");
}

const char* toString(UnknownSpace policy) {
  return policy == UnknownSpace::Optimistic ? "optimistic" : "conservative";
}

namespace {

class FusedWorld final : public CollisionWorld {
 public:
  FusedWorld(std::shared_ptr<const CollisionWorld> structure, std::unique_ptr<CollisionWorld> obstacles)
      : structure_(std::move(structure)), obstacles_(std::move(obstacles)) {}

  int dimensions() const override { return structure_->dimensions(); }
  Vec3 boundsMin() const override { return structure_->boundsMin(); }
  Vec3 boundsMax() const override { return structure_->boundsMax(); }
  double robotRadius() const override { return structure_->robotRadius(); }

  bool isFree(const Vec3& p) const override {
    countCheck();
    // The ellipsoids first: a few shapes through a grid, cheaper than the voxel ball scan.
    return obstacles_->isFree(p) && structure_->isFree(p);
  }

  bool isSegmentFree(const Vec3& a, const Vec3& b) const override {
    // The obstacle world has its own (exact, faster) segment test at our step; the shared structure is
    // sampled here at the same step, so that its own setting is never written by one of its users.
    obstacles_->setCheckResolution(checkResolution());
    const double length = (b - a).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(length / checkResolution())));
    countCheck(static_cast<std::uint64_t>(steps) + 1);
    if (!obstacles_->isSegmentFree(a, b)) return false;
    if (!structure_->isFree(b)) return false;
    for (int i = steps - 1; i >= 0; --i)
      if (!structure_->isFree(a + (b - a) * (static_cast<double>(i) / steps))) return false;
    return true;
  }

  double clearance(const Vec3& p) const override { return std::min(obstacles_->clearance(p), structure_->clearance(p)); }

  std::vector<NearbyObstacle> obstaclesNear(const Vec3& p, double range) const override {
    // The structure's nearest voxel per 8x8x8-voxel brick (OctoMap world ids are brick * 512 + bit, nearest
    // first): contact-based planners treat each entry as an obstacle and compare them pairwise, and a hill
    // flank within range holds thousands of voxels — one per brick keeps the contact shape at brick size.
    std::vector<NearbyObstacle> out;
    std::unordered_set<int> bricks;
    for (const auto& o : structure_->nearestPerBrick(p, range)) {
      const int brick = o.id / 512;
      if (!bricks.insert(brick).second) continue;
      out.push_back({2 * o.id, o.nearest_point, o.distance});
    }
    for (auto o : obstacles_->obstaclesNear(p, range)) {
      o.id = 2 * o.id + 1;
      out.push_back(o);
    }
    std::stable_sort(out.begin(), out.end(), [](const NearbyObstacle& x, const NearbyObstacle& y) { return x.distance < y.distance; });
    return out;
  }

 private:
  std::shared_ptr<const CollisionWorld> structure_;
  std::unique_ptr<CollisionWorld> obstacles_;
};

}  // namespace

std::unique_ptr<CollisionWorld> makeFusedWorld(std::shared_ptr<const CollisionWorld> structure,
                                               std::unique_ptr<CollisionWorld> obstacles) {
  if (!structure || !obstacles) throw std::invalid_argument("makeFusedWorld: both worlds are required");
  if (structure->dimensions() != obstacles->dimensions() || structure->robotRadius() != obstacles->robotRadius() ||
      !structure->boundsMin().isApprox(obstacles->boundsMin()) || !structure->boundsMax().isApprox(obstacles->boundsMax()))
    throw std::invalid_argument("makeFusedWorld: the structure and obstacle worlds differ in dimensions, bounds or robot radius");
  return std::make_unique<FusedWorld>(std::move(structure), std::move(obstacles));
}

}  // namespace ddsnav::planner
