// makeSensorViewWorld: a world in which the space a 3-D lidar's fan cannot see from the vehicle is blocked.
#include "ddsnav/planner/collision_world.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace ddsnav::planner {

namespace {

double slope(double degrees) { return std::tan(degrees * std::numbers::pi / 180.0); }

// SensorView::unseen with the fan's edges as slopes (dz per metre), computed once per world.
bool unseenWithSlopes(const SensorView& v, double slope_up, double slope_down, const Vec3& p) {
  const double dh = std::hypot(p.x() - v.origin.x(), p.y() - v.origin.y());
  if (!(dh > 0.0) || dh > v.range) return false;
  if (v.exempt_radius > 0.0 && (p - v.exempt_center).norm() <= v.exempt_radius) return false;
  const double dz = p.z() - v.origin.z();
  return dz > slope_up * dh + v.slack || (v.below && dz < slope_down * dh - v.slack);
}

}  // namespace

bool SensorView::unseen(const Vec3& p) const {
  return unseenWithSlopes(*this, slope(vertical_max_deg), slope(vertical_min_deg), p);
}

namespace {

class SensorViewWorld final : public CollisionWorld {
 public:
  SensorViewWorld(std::unique_ptr<CollisionWorld> world, const SensorView& view)
      : world_(std::move(world)), view_(view), slope_up_(slope(view.vertical_max_deg)), slope_down_(slope(view.vertical_min_deg)) {}

  int dimensions() const override { return world_->dimensions(); }
  Vec3 boundsMin() const override { return world_->boundsMin(); }
  Vec3 boundsMax() const override { return world_->boundsMax(); }
  double robotRadius() const override { return world_->robotRadius(); }

  bool isFree(const Vec3& p) const override {
    countCheck();
    return !unseen(p) && world_->isFree(p);
  }

  bool isSegmentFree(const Vec3& a, const Vec3& b) const override {
    // The view first (arithmetic only), at the world's step, then the world's own segment test.
    const double length = (b - a).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(length / checkResolution())));
    countCheck(static_cast<std::uint64_t>(steps) + 1);
    for (int i = 0; i <= steps; ++i)
      if (unseen(a + (b - a) * (static_cast<double>(i) / steps))) return false;
    world_->setCheckResolution(checkResolution());
    return world_->isSegmentFree(a, b);
  }

  double clearance(const Vec3& p) const override { return world_->clearance(p); }
  std::vector<NearbyObstacle> obstaclesNear(const Vec3& p, double range) const override { return world_->obstaclesNear(p, range); }
  std::vector<NearbyObstacle> nearestPerBrick(const Vec3& p, double range) const override { return world_->nearestPerBrick(p, range); }

 private:
  // Every validity check asks this: the fan's slopes are computed once, not two tangents per call.
  bool unseen(const Vec3& p) const { return unseenWithSlopes(view_, slope_up_, slope_down_, p); }

  std::unique_ptr<CollisionWorld> world_;
  SensorView view_;
  double slope_up_, slope_down_;
};

}  // namespace

std::unique_ptr<CollisionWorld> makeSensorViewWorld(std::unique_ptr<CollisionWorld> world, const SensorView& view) {
  if (!world) throw std::invalid_argument("makeSensorViewWorld: no world");
  if (world->dimensions() != 3) throw std::invalid_argument("makeSensorViewWorld: the sensor view applies to 3-D worlds only");
  if (!view.origin.allFinite()) throw std::invalid_argument("makeSensorViewWorld: the sensor origin is not finite");
  if (!(view.vertical_min_deg > -90.0 && view.vertical_min_deg < view.vertical_max_deg && view.vertical_max_deg < 90.0))
    throw std::invalid_argument("makeSensorViewWorld: the vertical field of view must satisfy -90 < min < max < 90 degrees");
  if (!(view.range >= 0.0 && view.range <= 1e6)) throw std::invalid_argument("makeSensorViewWorld: range must be in [0, 1e6] m");
  if (!(view.slack >= 0.0 && view.slack <= 1e3)) throw std::invalid_argument("makeSensorViewWorld: slack must be in [0, 1000] m");
  if (!view.exempt_center.allFinite() || !(view.exempt_radius >= 0.0 && view.exempt_radius <= 1e6))
    throw std::invalid_argument("makeSensorViewWorld: the exempt ball must be finite with a radius in [0, 1e6] m");
  return std::make_unique<SensorViewWorld>(std::move(world), view);
}

}  // namespace ddsnav::planner
