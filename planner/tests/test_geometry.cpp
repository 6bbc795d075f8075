// Geometry of the scenario and ellipsoid worlds against hand-computed points.
#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/scenario.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace ddsnav::planner {
namespace {

Scenario world2d(double robot_radius, std::vector<Obstacle> obstacles) {
  Scenario s;
  s.dimensions = 2;
  s.bounds_min = Vec3(-20, -20, 0);
  s.bounds_max = Vec3(20, 20, 0);
  s.robot_radius = robot_radius;
  s.obstacles = std::move(obstacles);
  return s;
}

Obstacle box(Vec3 center, Vec3 size, double yaw = 0.0) {
  Obstacle o;
  o.type = ObstacleType::Box;
  o.center = center;
  o.size = size;
  o.yaw = yaw;
  return o;
}

Obstacle ellipse(Vec3 center, Vec3 semi, double yaw = 0.0) {
  Obstacle o;
  o.type = ObstacleType::Ellipsoid;
  o.center = center;
  o.semi_axes = semi;
  o.yaw = yaw;
  return o;
}

// Distance from p to the ellipse x^2/a^2 + y^2/b^2 = 1 by dense sampling of its boundary: slow, simple and
// independent of the world's root finding.
double sampledEllipseDistance(double a, double b, double px, double py) {
  double best = 1e300;
  for (int i = 0; i < 2000000; ++i) {
    const double t = 2.0 * std::numbers::pi * i / 2000000.0;
    best = std::min(best, std::hypot(a * std::cos(t) - px, b * std::sin(t) - py));
  }
  return best;
}

TEST(Geometry, BoxRotatedAboutZHonoursRobotRadius) {
  // A 4 x 2 box turned by 90 degrees covers x in [-1, 1], y in [-2, 2].
  const auto world = makeScenarioWorld(world2d(0.5, {box(Vec3::Zero(), Vec3(4, 2, 0), std::numbers::pi / 2)}));
  EXPECT_TRUE(world->isFree(Vec3(1.6, 0, 0)));   // 0.6 from the face
  EXPECT_FALSE(world->isFree(Vec3(1.4, 0, 0)));  // 0.4 from the face (inside the box if it were not rotated)
  EXPECT_TRUE(world->isFree(Vec3(0, 2.6, 0)));
  EXPECT_FALSE(world->isFree(Vec3(0, 2.4, 0)));
  // Corner (1, 2): a point 0.45 away diagonally collides, 0.55 away is free.
  const Vec3 diag = Vec3(1, 1, 0).normalized();
  EXPECT_FALSE(world->isFree(Vec3(1, 2, 0) + 0.45 * diag));
  EXPECT_TRUE(world->isFree(Vec3(1, 2, 0) + 0.55 * diag));
}

TEST(Geometry, BoxAt45DegreesHasItsCornerOnTheXAxis) {
  // A 2 x 2 square turned by 45 degrees has a corner at (sqrt 2, 0).
  const auto world = makeScenarioWorld(world2d(0.5, {box(Vec3::Zero(), Vec3(2, 2, 0), std::numbers::pi / 4)}));
  EXPECT_FALSE(world->isFree(Vec3(std::sqrt(2.0) + 0.49, 0, 0)));
  EXPECT_TRUE(world->isFree(Vec3(std::sqrt(2.0) + 0.51, 0, 0)));
  EXPECT_NEAR(world->clearance(Vec3(3, 0, 0)), 3 - std::sqrt(2.0) - 0.5, 1e-12);
}

TEST(Geometry, EllipseDistanceIsExactNotAScaledRadius) {
  // Semi-axes 4 x 1: at (2, 1.5) the true distance differs from any radial scaling.
  const double truth = sampledEllipseDistance(4, 1, 2, 1.5);
  const double radial = std::hypot(2, 1.5) * (1 - 1 / std::sqrt(4.0 / 16 + 2.25));  // along the ray to the centre
  ASSERT_GT(std::abs(truth - radial), 0.02);
  auto near = [&](double r) { return makeScenarioWorld(world2d(r, {ellipse(Vec3::Zero(), Vec3(4, 1, 0))})); };
  EXPECT_FALSE(near(truth + 0.005)->isFree(Vec3(2, 1.5, 0)));
  EXPECT_TRUE(near(truth - 0.005)->isFree(Vec3(2, 1.5, 0)));
  EXPECT_NEAR(near(0.0)->clearance(Vec3(2, 1.5, 0)), truth, 1e-6);
  // Hand-computed: on the axes the distance is the gap to the vertex.
  EXPECT_NEAR(near(0.0)->clearance(Vec3(0, 3, 0)), 2.0, 1e-9);
  EXPECT_NEAR(near(0.0)->clearance(Vec3(7, 0, 0)), 3.0, 1e-9);
}

TEST(Geometry, EllipseRotatedAboutZ) {
  // Semi-axes 2 x 1 turned by 90 degrees: 2 along y, 1 along x.
  const auto world = makeScenarioWorld(world2d(0.5, {ellipse(Vec3(1, 1, 0), Vec3(2, 1, 0), std::numbers::pi / 2)}));
  EXPECT_TRUE(world->isFree(Vec3(1, 1 + 2.6, 0)));
  EXPECT_FALSE(world->isFree(Vec3(1, 1 + 2.4, 0)));
  EXPECT_TRUE(world->isFree(Vec3(1 + 1.6, 1, 0)));
  EXPECT_FALSE(world->isFree(Vec3(1 + 1.4, 1, 0)));
  const auto near = world->obstaclesNear(Vec3(1, 5, 0), 5.0);
  ASSERT_EQ(near.size(), 1u);
  EXPECT_NEAR(near[0].distance, 2.0, 1e-9);
  EXPECT_NEAR((near[0].nearest_point - Vec3(1, 3, 0)).norm(), 0.0, 1e-9);
}

TEST(Geometry, EllipsoidIn3DAndSphere) {
  Scenario s = world2d(0.5, {});
  s.dimensions = 3;
  s.bounds_min = Vec3(-20, -20, -20);
  s.bounds_max = Vec3(20, 20, 20);
  Obstacle e = ellipse(Vec3::Zero(), Vec3(3, 2, 1));
  Obstacle ball;
  ball.type = ObstacleType::Sphere;
  ball.center = Vec3(10, 10, 10);
  ball.radius = 2;
  s.obstacles = {e, ball};
  const auto world = makeScenarioWorld(s);
  EXPECT_NEAR(world->clearance(Vec3(0, 0, 2)), 1.0 - 0.5, 1e-9);
  EXPECT_FALSE(world->isFree(Vec3(0, 0, 1.45)));
  EXPECT_TRUE(world->isFree(Vec3(0, 0, 1.55)));
  EXPECT_TRUE(world->isFree(Vec3(10, 10, 12.6)));
  EXPECT_FALSE(world->isFree(Vec3(10, 10, 12.4)));
}

TEST(Geometry, HillHeightAndGround) {
  Scenario s;
  s.dimensions = 3;
  s.bounds_min = Vec3(0, 0, 0);
  s.bounds_max = Vec3(120, 120, 60);
  s.robot_radius = 0.0;
  Obstacle hill;
  hill.type = ObstacleType::Hill;
  hill.center = Vec3(60, 60, 0);
  hill.height = 40;
  hill.sigma = 12;
  s.obstacles = {hill};
  const auto point = makeScenarioWorld(s);
  // At d = sigma the surface is at 40 exp(-1/2) = 24.2612.
  EXPECT_FALSE(point->isFree(Vec3(72, 60, 24.25)));
  EXPECT_TRUE(point->isFree(Vec3(72, 60, 24.28)));
  EXPECT_FALSE(point->isFree(Vec3(60, 60, 39.99)));
  EXPECT_TRUE(point->isFree(Vec3(60, 60, 40.01)));

  s.robot_radius = 0.5;
  const auto ball = makeScenarioWorld(s);
  // Over the (flat) peak the nearest surface point is the peak itself.
  EXPECT_TRUE(ball->isFree(Vec3(60, 60, 40.55)));
  EXPECT_FALSE(ball->isFree(Vec3(60, 60, 40.45)));
  EXPECT_NEAR(ball->clearance(Vec3(60, 60, 42)), 2.0 - 0.5, 1e-6);
  // On the steep flank (slope about 2) a ball 0.6 m above the surface still touches it sideways.
  EXPECT_FALSE(ball->isFree(Vec3(72, 60, 24.2612 + 0.6)));
  // Far from the hill the ground (z <= 0) is solid.
  EXPECT_FALSE(ball->isFree(Vec3(5, 5, 0.45)));
  EXPECT_TRUE(ball->isFree(Vec3(5, 5, 0.55)));
}

TEST(Geometry, BoundsHonourRobotRadius) {
  const auto world = makeScenarioWorld(world2d(0.5, {}));
  EXPECT_FALSE(world->isFree(Vec3(-19.6, 0, 0)));
  EXPECT_TRUE(world->isFree(Vec3(-19.4, 0, 0)));
  EXPECT_FALSE(world->isFree(Vec3(0, 25, 0)));
  EXPECT_FALSE(world->isFree(Vec3(NAN, 0, 0)));
}

TEST(Geometry, SegmentsPassingABoxFaceAndCorner) {
  const auto world = makeScenarioWorld(world2d(0.5, {box(Vec3(1, 1, 0), Vec3(2, 2, 0))}));  // [0,2] x [0,2]
  EXPECT_FALSE(world->isSegmentFree(Vec3(-5, 2.45, 0), Vec3(5, 2.45, 0)));
  EXPECT_TRUE(world->isSegmentFree(Vec3(-5, 2.55, 0), Vec3(5, 2.55, 0)));
  // Passing the corner (2, 2) diagonally at 0.45 / 0.55.
  const Vec3 n = Vec3(1, -1, 0).normalized(), t = Vec3(1, 1, 0).normalized();
  const Vec3 corner(2, 2, 0);
  EXPECT_FALSE(world->isSegmentFree(corner + 0.45 * Vec3(1, 1, 0).normalized() + 5 * n, corner + 0.45 * t - 5 * n));
  EXPECT_TRUE(world->isSegmentFree(corner + 0.55 * t + 5 * n, corner + 0.55 * t - 5 * n));
  // A wall two check steps thick between free ends is found even though both ends are far from it.
  const auto wall = makeScenarioWorld(world2d(0.0, {box(Vec3(0, 0, 0), Vec3(0.1, 10, 0))}));
  EXPECT_FALSE(wall->isSegmentFree(Vec3(-3, 0, 0), Vec3(3, 0.1, 0)));
  EXPECT_TRUE(wall->isSegmentFree(Vec3(-3, 0, 0), Vec3(-0.06, 0.1, 0)));
  // A long segment with no obstacle near it costs its two end states only.
  wall->resetValidityChecks();
  EXPECT_TRUE(wall->isSegmentFree(Vec3(5, -15, 0), Vec3(15, 15, 0)));
  EXPECT_EQ(wall->validityChecks(), 2u);
}

TEST(Geometry, ObstaclesNearAreSortedWithNearestPoints) {
  Obstacle ball;
  ball.type = ObstacleType::Sphere;
  ball.center = Vec3(8, 1, 0);
  ball.radius = 1;
  const auto world = makeScenarioWorld(world2d(0.5, {box(Vec3(1, 1, 0), Vec3(2, 2, 0)), ball}));
  const auto near = world->obstaclesNear(Vec3(4, 1, 0), 3.5);
  ASSERT_EQ(near.size(), 2u);
  EXPECT_EQ(near[0].id, 0);
  EXPECT_NEAR(near[0].distance, 2.0, 1e-12);
  EXPECT_NEAR((near[0].nearest_point - Vec3(2, 1, 0)).norm(), 0.0, 1e-12);
  EXPECT_EQ(near[1].id, 1);
  EXPECT_NEAR(near[1].distance, 3.0, 1e-12);
  EXPECT_EQ(world->obstaclesNear(Vec3(4, 1, 0), 1.0).size(), 0u);
  EXPECT_NEAR(world->clearance(Vec3(4, 1, 0)), 1.5, 1e-12);
}

TEST(Geometry, EllipsoidWorldMatchesScenarioGeometry) {
  EllipsoidObstacle e;
  e.id = 7;
  e.center = Vec3(1, 1, 0);
  e.semi_axes = Vec3(2, 1, 0);
  e.axes << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // first axis along +y
  const auto world = makeEllipsoidWorld(2, Vec3(-20, -20, 0), Vec3(20, 20, 0), 0.5, {e});
  EXPECT_TRUE(world->isFree(Vec3(1, 3.6, 0)));
  EXPECT_FALSE(world->isFree(Vec3(1, 3.4, 0)));
  EXPECT_FALSE(world->isFree(Vec3(2.4, 1, 0)));
  const auto near = world->obstaclesNear(Vec3(1, 5, 0), 10);
  ASSERT_EQ(near.size(), 1u);
  EXPECT_EQ(near[0].id, 7);
  EllipsoidObstacle bad = e;
  bad.semi_axes.x() = -1;
  EXPECT_THROW(makeEllipsoidWorld(2, Vec3(-20, -20, 0), Vec3(20, 20, 0), 0.5, {bad}), std::invalid_argument);
  bad = e;
  bad.axes(0, 0) = 2;
  EXPECT_THROW(makeEllipsoidWorld(2, Vec3(-20, -20, 0), Vec3(20, 20, 0), 0.5, {bad}), std::invalid_argument);
  EXPECT_THROW(makeEllipsoidWorld(2, Vec3(0, 0, 0), Vec3(0, 20, 0), 0.5, {}), std::invalid_argument);
}

TEST(Geometry, EllipsoidWorldIn3DWithAnyOrientation) {
  EllipsoidObstacle e;
  e.id = 3;
  e.center = Vec3(0, 0, 0);
  e.semi_axes = Vec3(3, 1, 1);
  e.axes << 0, 0, 1, 0, 1, 0, -1, 0, 0;  // columns (0,0,-1), (0,1,0), (1,0,0): the long axis along z
  const auto world = makeEllipsoidWorld(3, Vec3(-10, -10, -10), Vec3(10, 10, 10), 0.5, {e});
  EXPECT_TRUE(world->isFree(Vec3(0, 0, 3.6)));
  EXPECT_FALSE(world->isFree(Vec3(0, 0, 3.4)));
  EXPECT_FALSE(world->isFree(Vec3(1.4, 0, 0)));
  EXPECT_TRUE(world->isFree(Vec3(1.6, 0, 0)));
  EXPECT_NEAR(world->clearance(Vec3(0, 4, 0)), 4 - 1 - 0.5, 1e-9);
  EXPECT_FALSE(world->isSegmentFree(Vec3(-5, 0, 2.0), Vec3(5, 0, 2.0)));  // crosses the ellipsoid at z = 2
  EXPECT_TRUE(world->isSegmentFree(Vec3(-5, 1.6, 0), Vec3(5, 1.6, 0)));
}

TEST(Geometry, HundredsOfObstaclesStayCorrectWithTheGrid) {
  // Brute force over every obstacle must agree with the broad phase.
  std::vector<Obstacle> obstacles;
  for (int i = 0; i < 300; ++i) {
    const double x = -18 + (i * 7919 % 3600) / 100.0, y = -18 + (i * 104729 % 3600) / 100.0;
    obstacles.push_back(i % 2 ? box(Vec3(x, y, 0), Vec3(0.5 + i % 3, 0.4 + i % 2, 0), i * 0.1)
                              : ellipse(Vec3(x, y, 0), Vec3(0.3 + i % 4 * 0.3, 0.2 + i % 3 * 0.2, 0), i * 0.2));
  }
  const Scenario s = world2d(0.3, obstacles);
  const auto world = makeScenarioWorld(s);
  std::vector<std::unique_ptr<CollisionWorld>> singles;
  for (const Obstacle& o : obstacles) singles.push_back(makeScenarioWorld(world2d(0.3, {o})));
  int disagreements = 0, occupied = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p(-19 + (i * 37 % 380) / 10.0, -19 + (i * 53 % 380) / 10.0 + (i % 7) * 0.013, 0);
    bool free = world->isFree(p);
    bool brute = true;
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& w : singles) {
      brute = brute && w->isFree(p);
      nearest = std::min(nearest, w->clearance(p));
    }
    disagreements += free != brute;
    occupied += !brute;
    ASSERT_DOUBLE_EQ(world->clearance(p), nearest) << p.transpose();
  }
  EXPECT_EQ(disagreements, 0);
  EXPECT_GT(occupied, 100);
}

}  // namespace
}  // namespace ddsnav::planner
