#pragma once
// Exact geometry of obstacle primitives (boxes rotated about z, spheres, ellipsoids with any orientation,
// Gaussian hills) behind the CollisionWorld interface, with a uniform xy grid as broad phase.
// Private to the planner library: makeScenarioWorld and makeEllipsoidWorld both build a ShapeWorld.

#include "ddsnav/planner/collision_world.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace ddsnav::planner::detail {

struct Shape {
  ObstacleType type = ObstacleType::Box;
  int id = -1;
  Vec3 center = Vec3::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // columns: local axes in world frame
  Vec3 half = Vec3::Zero();                           // box half sizes / ellipsoid semi-axes
  double radius = 0.0;                                // sphere
  double height = 0.0, sigma = 0.0;                   // hill
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();          // axis-aligned bounds of the shape itself
};

// Height below which a hill is treated as gone (it has Gaussian tails that never reach zero).
inline constexpr double kHillCutoff = 1e-6;

// Signed distance from p to the shape's surface (negative inside) and the nearest surface point.
// `dimensions` 2 ignores z everywhere.
double signedDistance(const Shape& s, int dimensions, const Vec3& p, Vec3* nearest = nullptr);

// Signed distance from a point to an axis-aligned ellipse/ellipsoid centred at the origin, computed
// exactly (root of the Lagrange condition); y in local coordinates. Returns the nearest point in `x`.
double ellipsoidDistance(int n, const double* e, const double* y, double* x);

class ShapeWorld final : public CollisionWorld {
 public:
  ShapeWorld(int dimensions, const Vec3& bounds_min, const Vec3& bounds_max, double robot_radius,
             std::vector<Shape> shapes);

  int dimensions() const override { return dims_; }
  Vec3 boundsMin() const override { return bmin_; }
  Vec3 boundsMax() const override { return bmax_; }
  double robotRadius() const override { return radius_; }
  bool isFree(const Vec3& p) const override;
  bool isSegmentFree(const Vec3& a, const Vec3& b) const override;
  double clearance(const Vec3& p) const override;
  std::vector<NearbyObstacle> obstaclesNear(const Vec3& p, double range) const override;

  const std::vector<Shape>& shapes() const { return shapes_; }

 private:
  bool insideBounds(const Vec3& p) const;
  bool collides(const Shape& s, const Vec3& p) const;  // the robot at p touches s
  double distanceLowerBound(const Shape& s, const Vec3& p) const;  // <= distance from p to s, cheap
  // Whether the robot moving along a-b touches shape `index` (exact for convex shapes).
  bool segmentTouches(const Shape& s, int index, const Vec3& a, const Vec3& b, std::uint64_t& evaluations) const;
  bool freeAgainst(const Vec3& p, const int* candidates, int count) const;
  int cellIndex(int cx, int cy) const { return cy * nx_ + cx; }
  int cellX(double x) const;
  int cellY(double y) const;
  // Shapes registered in the cells overlapping the xy box [lo, hi] whose inflated bounds overlap it.
  void gather(const Vec3& lo, const Vec3& hi, std::vector<int>& out) const;

  int dims_;
  Vec3 bmin_, bmax_;
  double radius_;
  std::vector<Shape> shapes_;
  std::vector<Vec3> inflated_lo_, inflated_hi_;  // shape bounds grown by the robot radius
  bool has_ground_ = false;                      // hills imply solid ground at z <= 0
  // Uniform xy grid, CSR layout: cell c holds cell_items_[cell_start_[c] .. cell_start_[c+1]).
  double cell_size_ = 1.0;
  int nx_ = 1, ny_ = 1;
  std::vector<int> cell_start_;
  std::vector<int> cell_items_;
};

}  // namespace ddsnav::planner::detail
