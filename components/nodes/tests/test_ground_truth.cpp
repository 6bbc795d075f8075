// The monitor's ground-truth judgements: feasibility of the goal and clearance of the driven track.
#include "ddsnav/nodes/ground_truth.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace ddsnav;

namespace {

const std::string kScenarios = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/";

planner::Obstacle box(const planner::Vec3& lo, const planner::Vec3& hi) {
  planner::Obstacle o;
  o.type = planner::ObstacleType::Box;
  o.center = 0.5 * (lo + hi);
  o.size = hi - lo;
  return o;
}

// 20 x 10 m, start on the left, goal on the right, a wall across x = 10 with a 2 m gap at the top.
planner::Scenario yard() {
  planner::Scenario s;
  s.name = "yard";
  s.source = "yard.yaml";
  s.dimensions = 2;
  s.bounds_max = {20, 10, 0};
  s.robot_radius = 0.4;
  s.start = {2, 5, 0};
  s.goal = {18, 5, 0};
  s.goal_radius = 1.0;
  s.obstacles.push_back(box({9.5, 0, 0}, {10.5, 8, 0}));
  return s;
}

TEST(GroundTruth, AYardWithAGapIsFeasible) {
  const auto f = nodes::checkGoalFeasible(yard());
  EXPECT_TRUE(f.feasible) << f.why;
}

TEST(GroundTruth, AClosedWallMakesTheGoalUnreachable) {
  auto s = yard();
  s.obstacles.push_back(box({9.5, 8, 0}, {10.5, 10, 0}));
  const auto f = nodes::checkGoalFeasible(s);
  EXPECT_FALSE(f.feasible);
  EXPECT_NE(f.why.find("unreachable"), std::string::npos) << f.why;
  // A gap narrower than the robot is closed too, even on the optimistic grid's finest cells.
  auto narrow = yard();
  narrow.obstacles.push_back(box({9.5, 8.3, 0}, {10.5, 10, 0}));  // 0.3 m gap, robot 0.8 m wide
  EXPECT_FALSE(nodes::checkGoalFeasible(narrow, std::size_t{1} << 22).feasible);
}

TEST(GroundTruth, AGoalInsideAnObstacleIsNamed) {
  auto s = yard();
  s.obstacles.push_back(box({16, 3, 0}, {20, 7, 0}));
  const auto f = nodes::checkGoalFeasible(s);
  EXPECT_FALSE(f.feasible);
  EXPECT_NE(f.why.find("inside obstacle #2 (box at (18, 5))"), std::string::npos) << f.why;
  // The goal point in an obstacle whose edge leaves part of the goal region free: still reachable.
  auto edge = yard();
  edge.obstacles.push_back(box({17.5, 0, 0}, {20, 10, 0}));
  edge.goal_radius = 2.0;
  EXPECT_TRUE(nodes::checkGoalFeasible(edge).feasible);
}

TEST(GroundTruth, AStartInCollisionIsNamed) {
  auto s = yard();
  s.start = {10, 4, 0};
  const auto f = nodes::checkGoalFeasible(s);
  EXPECT_FALSE(f.feasible);
  EXPECT_NE(f.why.find("start (10, 4) is in collision"), std::string::npos) << f.why;
}

TEST(GroundTruth, ShippedScenariosAreFeasible) {
  for (const char* file : {"demo_2d.yaml", "gart_cluttered_2d.yaml", "gart_terrain_3d.yaml", "auv_coastal.yaml", "auv_harbour.yaml",
                           "bugtrap_1.0.yaml", "stunnel_1.0.yaml", "stunnel_small_0.3.yaml"}) {
    const auto f = nodes::checkGoalFeasible(planner::loadScenario(kScenarios + file));
    EXPECT_TRUE(f.feasible) << file << ": " << f.why;
  }
}

TEST(GroundTruth, MinClearanceOfATrackSubtractsTheRobotRadius) {
  const auto s = yard();
  // Closest point 1.5 m from the wall's face at x = 9.5: clearance 1.5 - 0.4.
  EXPECT_NEAR(*nodes::minTrueClearance(s, {{2, 5, 0}, {8, 5, 0}, {8, 8.4, 0}}), 1.1, 1e-9);
  // A track through the wall: negative.
  EXPECT_LT(*nodes::minTrueClearance(s, {{9.8, 5, 0}}), 0.0);
  EXPECT_FALSE(nodes::minTrueClearance(s, {}).has_value());
  // Where: (8, 5), 1.5 m from the face; (8, 8.4) is 1.55 m from the corner (9.5, 8) and 1.6 m from the top bound.
  const auto closest = nodes::closestApproach(s, {{2, 5, 0}, {8, 5, 0}, {8, 8.4, 0}, {3, 7, 0}});
  ASSERT_TRUE(closest.has_value());
  EXPECT_EQ(closest->index, 1u);
  EXPECT_NEAR(closest->clearance_m, 1.1, 1e-9);
  EXPECT_FALSE(closest->to_bounds);
}

// The bounds' faces count as the scenario format's validity rule has them (the robot lies inside the bounds): a track
// along the yard's top edge is nearest to it, one that leaves the bounds is negative, and a world without obstacles
// has a clearance too (a run there used to report none).
TEST(GroundTruth, MinClearanceCountsTheBoundsFaces) {
  auto s = yard();
  const auto along_top = nodes::closestApproach(s, {{2, 5, 0}, {4, 9.2, 0}});
  ASSERT_TRUE(along_top.has_value());
  EXPECT_EQ(along_top->index, 1u);
  EXPECT_NEAR(along_top->clearance_m, 0.8 - 0.4, 1e-9);
  EXPECT_TRUE(along_top->to_bounds);
  EXPECT_LT(*nodes::minTrueClearance(s, {{2, 5, 0}, {-0.1, 5, 0}}), 0.0);
  s.obstacles.clear();
  EXPECT_NEAR(*nodes::minTrueClearance(s, {{2, 5, 0}, {15, 3, 0}}), 1.6, 1e-9);
  // In 3-D the z faces count as well; in 2-D z does not.
  s.dimensions = 3;
  s.bounds_max = {20, 10, 6};
  EXPECT_NEAR(*nodes::minTrueClearance(s, {{5, 5, 1.0}}), 0.6, 1e-9);
}

}  // namespace
