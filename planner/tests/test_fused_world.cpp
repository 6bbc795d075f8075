// The fused world (OctoMap structure + obstacle ellipsoids): blocked where either source blocks, unknown
// space as the structure's policy says, merged contact lists with distinct ids.
#include "ddsnav/planner/collision_world.hpp"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <sstream>

namespace ddsnav::planner {
namespace {

const Vec3 kMin(0, 0, 0), kMax(20, 20, 10);
constexpr double kRadius = 0.5;

std::vector<std::uint8_t> toBytes(const octomap::OcTree& tree) {
  std::ostringstream s;
  tree.writeBinaryConst(s);
  const std::string str = s.str();
  return {str.begin(), str.end()};
}

// A wall at x = 10 (y 0..8, z 0..4) seen from (2, 4, 2): the space between the sensor and the wall is
// observed free, the rest of the box (e.g. behind the wall, or y > 12) is unknown.
std::vector<std::uint8_t> wallMap() {
  octomap::OcTree tree(0.2);
  octomap::Pointcloud cloud;
  for (double y = 0.1; y < 8.0; y += 0.1)
    for (double z = 0.1; z < 4.0; z += 0.1) cloud.push_back(10.05f, float(y), float(z));
  tree.insertPointCloud(cloud, octomap::point3d(2.0f, 4.0f, 2.0f));
  return toBytes(tree);
}

std::unique_ptr<CollisionWorld> fused(UnknownSpace policy, std::vector<EllipsoidObstacle> obstacles) {
  OctoMapWorldOptions options;
  options.unknown_is_occupied = policy == UnknownSpace::Conservative;
  std::shared_ptr<const CollisionWorld> structure = makeOctoMapWorld(3, kMin, kMax, kRadius, wallMap(), options);
  return makeFusedWorld(structure, makeEllipsoidWorld(3, kMin, kMax, kRadius, std::move(obstacles)));
}

EllipsoidObstacle ball(int id, const Vec3& center, double r) {
  EllipsoidObstacle o;
  o.id = id;
  o.center = center;
  o.semi_axes = Vec3::Constant(r);
  return o;
}

TEST(FusedWorld, BlockedWhenEitherSourceSaysSo) {
  const auto world = fused(UnknownSpace::Optimistic, {ball(7, {5, 4, 2}, 1.0)});
  EXPECT_TRUE(world->isFree({3, 4, 2}));       // observed free, away from both
  EXPECT_FALSE(world->isFree({5, 4, 2}));      // inside the obstacle ellipsoid only (the map saw free space)
  EXPECT_FALSE(world->isFree({5, 5.4, 2}));    // the ball of the robot touches the ellipsoid
  EXPECT_FALSE(world->isFree({10.0, 4, 2}));   // in the mapped wall only
  EXPECT_FALSE(world->isFree({9.6, 4, 2}));    // the robot's ball touches the wall
  EXPECT_FALSE(world->isSegmentFree({3, 4, 2}, {7, 4, 2}));  // through the ellipsoid
  EXPECT_FALSE(world->isSegmentFree({8, 6, 3}, {12, 6, 3}));  // through the wall
  EXPECT_TRUE(world->isSegmentFree({3, 1, 1}, {8, 1, 1}));
  // Clearance is the nearer of the two: the ellipsoid's surface is 1.5 m from (2.5, 4, 2), minus the radius.
  EXPECT_NEAR(world->clearance({2.5, 4, 2}), 1.0, 1e-6);
  EXPECT_NEAR(world->clearance({8.5, 1, 2}), 1.5 - kRadius, 0.25);  // the wall's voxels start at x = 10
}

TEST(FusedWorld, UnknownSpaceFollowsThePolicy) {
  const Vec3 behind_wall(15, 4, 2), unseen_side(5, 16, 8), seen(6, 4, 2);
  const auto optimistic = fused(UnknownSpace::Optimistic, {});
  const auto conservative = fused(UnknownSpace::Conservative, {});
  EXPECT_TRUE(optimistic->isFree(behind_wall));
  EXPECT_TRUE(optimistic->isFree(unseen_side));
  EXPECT_FALSE(conservative->isFree(behind_wall));
  EXPECT_FALSE(conservative->isFree(unseen_side));
  EXPECT_TRUE(conservative->isFree(seen));  // observed free space is free under both
  EXPECT_TRUE(optimistic->isFree(seen));
  // An obstacle in unknown space blocks under both policies.
  EXPECT_FALSE(fused(UnknownSpace::Optimistic, {ball(1, behind_wall, 1.0)})->isFree(behind_wall));
}

TEST(FusedWorld, ContactListsMergeNearestFirstWithDistinctIds) {
  const auto world = fused(UnknownSpace::Optimistic, {ball(3, {8, 4, 2}, 0.5)});
  const auto near = world->obstaclesNear({7, 4, 2}, 3.5);
  ASSERT_FALSE(near.empty());
  EXPECT_EQ(near.front().id, 2 * 3 + 1);  // the ellipsoid (0.5 m away) before the wall (3 m away)
  EXPECT_NEAR(near.front().distance, 0.5, 1e-6);
  bool any_voxel = false;
  for (std::size_t i = 0; i < near.size(); ++i) {
    if (i > 0) {
      EXPECT_LE(near[i - 1].distance, near[i].distance);
    }
    if (near[i].id % 2 == 0) any_voxel = true;
  }
  EXPECT_TRUE(any_voxel);
}

// A vehicle that stands against a mapped wall (its ball touches the wall's voxels) plans from the nearest
// free state, a small step back on its own side of the wall — never through it.
TEST(FusedWorld, AStartAgainstTheMapMovesToTheNearestFreeStateOnItsSide) {
  const auto world = fused(UnknownSpace::Optimistic, {});
  const Vec3 against(9.62, 4, 2);  // 0.38 m from the wall's voxels (x >= 10), robot radius 0.5
  ASSERT_FALSE(world->isFree(against));
  const auto moved = nearestFreePosition(*world, against, kRadius, 0.05);
  ASSERT_TRUE(moved.has_value());
  EXPECT_TRUE(world->isFree(*moved));
  EXPECT_LE(moved->x(), 9.5 + 1e-9);                 // on the near side
  EXPECT_NEAR((*moved - against).norm(), 0.15, 1e-9);  // no farther than needed: 9.52 still touches
  // Asked for 0.2 m of clearance, it goes on to the nearest state that has it (x <= 9.3), within the nearest free
  // one's distance plus that; when none is within its reach, the nearest free one.
  const auto clear = nearestFreePosition(*world, against, kRadius, 0.05, 0.2);
  ASSERT_TRUE(clear.has_value());
  EXPECT_GE(world->clearance(*clear), 0.2 - 1e-9);
  EXPECT_NEAR((*clear - against).norm(), 0.35, 1e-9);
  EXPECT_EQ(*nearestFreePosition(*world, against, 0.3, 0.05, 0.2), *moved);  // 0.35 m away is beyond a reach of 0.3
  EXPECT_THROW(nearestFreePosition(*world, against, kRadius, 0.05, -1.0), std::invalid_argument);
  // A free position is its own answer; one inside the wall has no free state within the robot radius
  // (0.6 m to either side), so it gets none rather than one behind the wall.
  EXPECT_EQ(*nearestFreePosition(*world, Vec3(3, 4, 2), kRadius, 0.05), Vec3(3, 4, 2));
  EXPECT_FALSE(nearestFreePosition(*world, Vec3(10.1, 4, 2), kRadius, 0.05).has_value());
  // An obstacle ellipsoid counts as well: the state comes out of the ellipsoid's reach.
  const auto with_ball = fused(UnknownSpace::Optimistic, {ball(1, {5, 4, 2}, 1.0)});
  const auto out = nearestFreePosition(*with_ball, Vec3(5, 5.3, 2), kRadius, 0.05);
  ASSERT_TRUE(out.has_value());
  EXPECT_GE((*out - Vec3(5, 4, 2)).norm(), 1.5 - 1e-6);
  EXPECT_THROW(nearestFreePosition(*world, Vec3(std::nan(""), 0, 0), 0.5, 0.05), std::invalid_argument);
  EXPECT_THROW(nearestFreePosition(*world, against, -1.0, 0.05), std::invalid_argument);
  EXPECT_THROW(nearestFreePosition(*world, against, 0.5, 0.0), std::invalid_argument);
  EXPECT_THROW(nearestFreePosition(*world, against, 100.0, 0.01), std::invalid_argument);
}

// Terrain below z = 1 with a free pocket of 0.1 m radius inside it, 0.05 m from a buried start (a point robot): the
// nearest free position is in the pocket, from which nothing leads out; asked for a way out, it is the surface above.
class PocketWorld : public CollisionWorld {
 public:
  int dimensions() const override { return 3; }
  Vec3 boundsMin() const override { return {-5, -5, -5}; }
  Vec3 boundsMax() const override { return {5, 5, 5}; }
  double robotRadius() const override { return 0.0; }
  bool isFree(const Vec3& p) const override {
    countCheck();
    return p.z() >= 1.0 || (p - kPocket).norm() <= 0.1;
  }
  double clearance(const Vec3& p) const override { return p.z() >= 1.0 ? p.z() - 1.0 : 0.1 - (p - kPocket).norm(); }
  std::vector<NearbyObstacle> obstaclesNear(const Vec3&, double) const override { return {}; }
  static inline const Vec3 kPocket{0.15, 0.0, 0.8};
};

TEST(FusedWorld, ABuriedStartMovesToAFreeStateThatLeadsOut) {
  const PocketWorld world;
  const Vec3 buried(0, 0, 0.8);
  const auto nearest = nearestFreePosition(world, buried, 0.5, 0.05);
  ASSERT_TRUE(nearest.has_value());
  EXPECT_LT((*nearest - PocketWorld::kPocket).norm(), 0.1 + 1e-9);  // the pocket: 0.05 m away
  const auto out = nearestFreePosition(world, buried, 0.5, 0.05, 0.0, 0.5);
  ASSERT_TRUE(out.has_value());
  EXPECT_NEAR(out->z(), 1.0, 1e-9);  // straight up, 0.2 m away
  EXPECT_NEAR((*out - buried).norm(), 0.2, 1e-9);
  // No way out within reach: the answer is as without the requirement.
  EXPECT_EQ(*nearestFreePosition(world, buried, 0.15, 0.05, 0.0, 0.5), *nearest);
  EXPECT_THROW(nearestFreePosition(world, buried, 0.5, 0.05, 0.0, -1.0), std::invalid_argument);
}

TEST(SensorViewWorld, BlocksWhatTheFanCannotSeeNearTheVehicleOnly) {
  SensorView view;
  view.origin = Vec3(2, 4, 2);
  view.vertical_min_deg = -15;
  view.vertical_max_deg = 15;
  view.range = 6;
  view.slack = 0.5;
  const auto world = makeSensorViewWorld(fused(UnknownSpace::Optimistic, {}), view);
  const double up = std::tan(15.0 * M_PI / 180.0);
  // In the fan (and at the vehicle itself): what the world says.
  EXPECT_TRUE(world->isFree(view.origin));
  EXPECT_TRUE(world->isFree(Vec3(6, 4, 2 + 4 * up + 0.4)));
  EXPECT_TRUE(world->isFree(Vec3(6, 4, 2 - 4 * up - 0.4)));
  // Above or below it by more than the slack, within the range: blocked.
  EXPECT_FALSE(world->isFree(Vec3(6, 4, 2 + 4 * up + 0.6)));
  EXPECT_FALSE(world->isFree(Vec3(6, 4, 2 - 4 * up - 0.6)));
  EXPECT_FALSE(world->isFree(Vec3(2.5, 4, 3)));  // steeply above, close by
  // Beyond the range the optimistic policy is back.
  EXPECT_TRUE(world->isFree(Vec3(2, 10.5, 8)));
  // A climb steeper than the fan is blocked on the way, a gentle one is not; the wall still blocks.
  EXPECT_FALSE(world->isSegmentFree(Vec3(2, 4, 2), Vec3(5, 4, 4.5)));
  EXPECT_TRUE(world->isSegmentFree(Vec3(2, 4, 2), Vec3(7, 4, 3)));
  EXPECT_FALSE(world->isSegmentFree(Vec3(2, 4, 2), Vec3(12, 4, 2)));
  // The exempt ball (the goal region) is never unseen.
  SensorView to_goal = view;
  to_goal.exempt_center = Vec3(6, 4, 2 + 4 * up + 1.5);
  to_goal.exempt_radius = 1.0;
  const auto with_goal = makeSensorViewWorld(fused(UnknownSpace::Optimistic, {}), to_goal);
  EXPECT_TRUE(with_goal->isFree(to_goal.exempt_center));
  EXPECT_FALSE(with_goal->isFree(Vec3(6, 4, 2 + 4 * up + 3.0)));
  // Contact information is the world's: the unseen space is no obstacle.
  const auto plain = fused(UnknownSpace::Optimistic, {});
  EXPECT_DOUBLE_EQ(world->clearance(Vec3(6, 4, 5)), plain->clearance(Vec3(6, 4, 5)));
  // Bad views are refused.
  SensorView bad = view;
  bad.vertical_min_deg = 20;
  EXPECT_THROW(makeSensorViewWorld(fused(UnknownSpace::Optimistic, {}), bad), std::invalid_argument);
  bad = view;
  bad.origin.x() = std::nan("");
  EXPECT_THROW(makeSensorViewWorld(fused(UnknownSpace::Optimistic, {}), bad), std::invalid_argument);
  EXPECT_THROW(makeSensorViewWorld(makeEllipsoidWorld(2, Vec3(0, 0, 0), Vec3(5, 5, 0), 0.5, {}), view), std::invalid_argument);
}

TEST(FusedWorld, RefusesMismatchedSources) {
  std::shared_ptr<const CollisionWorld> structure = makeOctoMapWorld(3, kMin, kMax, kRadius, wallMap());
  EXPECT_THROW(makeFusedWorld(structure, makeEllipsoidWorld(3, kMin, kMax, 0.3, {})), std::invalid_argument);
  EXPECT_THROW(makeFusedWorld(nullptr, makeEllipsoidWorld(3, kMin, kMax, kRadius, {})), std::invalid_argument);
  EXPECT_EQ(parseUnknownSpace("conservative"), UnknownSpace::Conservative);
  EXPECT_THROW(parseUnknownSpace("maybe"), std::invalid_argument);
}

}  // namespace
}  // namespace ddsnav::planner
