#include "closest_obstacle.hpp"

#include <gtest/gtest.h>

using example::closestObstacle;
using example::Obstacle;

TEST(ClosestObstacle, NoObstacleNoAnswer) { EXPECT_FALSE(closestObstacle({}, {})); }

TEST(ClosestObstacle, NearestSurfaceWinsNotNearestCentre) {
  // The big obstacle's centre is farther, but its surface is nearer.
  const std::vector<Obstacle> obstacles = {{1, {4, 0, 0}, 0.5}, {2, {0, 6, 0}, 3.0}};
  const auto nearest = closestObstacle(obstacles, {0, 0, 0});
  ASSERT_TRUE(nearest);
  EXPECT_EQ(nearest->id, 2u);
  EXPECT_DOUBLE_EQ(nearest->distance, 3.0);
}

TEST(ClosestObstacle, InsideAnObstacleIsDistanceZeroAndTiesGoToTheLowerId) {
  const std::vector<Obstacle> obstacles = {{7, {1, 0, 0}, 2.0}, {3, {-1, 0, 0}, 2.0}};
  const auto nearest = closestObstacle(obstacles, {0, 0, 0});
  ASSERT_TRUE(nearest);
  EXPECT_EQ(nearest->id, 3u);
  EXPECT_EQ(nearest->distance, 0.0);
}
