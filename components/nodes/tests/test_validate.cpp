// The checks components run on messages from other processes (validate.hpp) and the conversions that rely
// on them. No DDS participant: messages are built in memory.

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"

#include <ddsnav/mapper/occupancy_mapper.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace ddsnav;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

msg::ObstacleEllipsoid ellipse(std::uint32_t id, double x, double y, double a, double b) {
  msg::ObstacleEllipsoid o;
  o.id(id);
  o.centre().x(x);
  o.centre().y(y);
  o.semi_axes().x(a);
  o.semi_axes().y(b);
  o.orientation().w(1.0);
  return o;
}

// Two planar ellipses in the map frame, as perception publishes them.
msg::ObstacleArray goodArray() {
  msg::ObstacleArray array;
  array.header().frame_id("map");
  array.planar(true);
  array.obstacles().push_back(ellipse(3, 5.0, 0.0, 1.0, 0.5));
  array.obstacles().push_back(ellipse(8, 2.0, 4.0, 0.3, 0.3));
  return array;
}

planner::Scenario box2d() {
  planner::Scenario s;
  s.dimensions = 2;
  s.bounds_min = {-10, -10, 0};
  s.bounds_max = {10, 10, 1};
  s.robot_radius = 0.2;
  return s;
}

}  // namespace

TEST(ObstacleArrayCheck, AcceptsWellFormedArrays) {
  EXPECT_EQ(nodes::checkObstacleArray(goodArray(), "map"), "");
  msg::ObstacleArray empty;
  empty.header().frame_id("map");
  EXPECT_EQ(nodes::checkObstacleArray(empty, "map"), "");
  auto solid = goodArray();
  solid.planar(false);
  for (auto& o : solid.obstacles()) o.semi_axes().z(0.4);
  EXPECT_EQ(nodes::checkObstacleArray(solid, "map"), "");
  const auto ellipses = nodes::toEllipsoidObstacles(goodArray());
  ASSERT_EQ(ellipses.size(), 2u);
  EXPECT_EQ(ellipses[1].id, 8);
  EXPECT_DOUBLE_EQ(ellipses[0].semi_axes.x(), 1.0);
}

TEST(ObstacleArrayCheck, NamesTheObstacleAndWhatIsWrong) {
  auto negative = goodArray();
  negative.obstacles()[1].semi_axes().y(-0.5);
  const auto error = nodes::checkObstacleArray(negative, "map");
  EXPECT_NE(error.find("obstacle 1 (id 8)"), std::string::npos) << error;
  EXPECT_NE(error.find("semi-axis y"), std::string::npos) << error;

  auto nan_centre = goodArray();
  nan_centre.obstacles()[0].centre().x(kNaN);
  EXPECT_NE(nodes::checkObstacleArray(nan_centre, "map").find("obstacle 0 (id 3): non-finite centre"), std::string::npos);

  auto inf_axis = goodArray();
  inf_axis.obstacles()[0].semi_axes().x(kInf);
  EXPECT_NE(nodes::checkObstacleArray(inf_axis, "map").find("non-finite semi-axes"), std::string::npos);

  auto zero_axis = goodArray();
  zero_axis.obstacles()[0].semi_axes().x(0.0);
  EXPECT_NE(nodes::checkObstacleArray(zero_axis, "map").find("semi-axis x is 0"), std::string::npos);

  auto zero_quaternion = goodArray();
  zero_quaternion.obstacles()[0].orientation().w(0.0);
  EXPECT_NE(nodes::checkObstacleArray(zero_quaternion, "map").find("zero norm"), std::string::npos);

  auto nan_quaternion = goodArray();
  nan_quaternion.obstacles()[0].orientation().z(kNaN);
  EXPECT_NE(nodes::checkObstacleArray(nan_quaternion, "map").find("non-finite orientation"), std::string::npos);

  auto bad_covariance = goodArray();
  bad_covariance.obstacles()[1].covariance()[4] = kInf;
  EXPECT_NE(nodes::checkObstacleArray(bad_covariance, "map").find("non-finite covariance"), std::string::npos);

  // A 3-D array needs a positive z semi-axis; a planar one has z = 0 but never a negative one.
  auto flat_solid = goodArray();
  flat_solid.planar(false);
  EXPECT_NE(nodes::checkObstacleArray(flat_solid, "map").find("semi-axis z is 0"), std::string::npos);
  auto negative_z = goodArray();
  negative_z.obstacles()[0].semi_axes().z(-1.0);
  EXPECT_NE(nodes::checkObstacleArray(negative_z, "map").find("semi-axis z"), std::string::npos);
}

// Found by tests/fuzz (target cdr; corpus/cdr/regress-huge-obstacle-*): finite but absurd sizes passed the
// check and overflowed the collision grid's int cell index (UBSan) in makeEllipsoidWorld.
TEST(ObstacleArrayCheck, RefusesObstaclesBeyondAnyWorld) {
  auto far = goodArray();
  far.obstacles()[0].centre().y(1e300);
  EXPECT_NE(nodes::checkObstacleArray(far, "map").find("obstacle 0 (id 3): centre (5, 1e+300, 0) or semi-axes"), std::string::npos)
      << nodes::checkObstacleArray(far, "map");
  auto huge = goodArray();
  huge.obstacles()[1].semi_axes().x(2.4e275);
  EXPECT_NE(nodes::checkObstacleArray(huge, "map").find("beyond 1000000 m"), std::string::npos);
  EXPECT_THROW(nodes::toEllipsoidObstacles(huge), std::invalid_argument);
  auto large = goodArray();
  large.obstacles()[0].centre().x(-9.9e5);
  EXPECT_EQ(nodes::checkObstacleArray(large, "map"), "");
}

TEST(ObstacleArrayCheck, RefusesAForeignFrameUnlessAnyFrameIsAsked) {
  auto lidar = goodArray();
  lidar.header().frame_id("lidar");
  EXPECT_NE(nodes::checkObstacleArray(lidar, "map").find("frame 'lidar', expected 'map'"), std::string::npos);
  EXPECT_EQ(nodes::checkObstacleArray(lidar, ""), "");
}

TEST(ObstacleArrayCheck, ConversionRefusesMalformedObstacles) {
  auto negative = goodArray();
  negative.obstacles()[0].semi_axes().x(-1.0);
  EXPECT_THROW(nodes::toEllipsoidObstacles(negative), std::invalid_argument);
  auto zero_quaternion = goodArray();
  zero_quaternion.obstacles()[1].orientation().w(0.0);
  EXPECT_THROW(nodes::toEllipsoidObstacles(zero_quaternion), std::invalid_argument);
}

TEST(OccupancyMapCheck, AcceptsTheMappersOutputAndRefusesOtherBytes) {
  mapper::MapperConfig config;
  config.dimensions = 2;
  config.resolution = 0.1;
  mapper::OccupancyMapper mapper(config);
  mapper::Scan scan;
  for (int i = 0; i <= 20; ++i) scan.points.push_back({5.0f, -0.5f + 0.05f * i, 0.0f});
  ASSERT_TRUE(mapper.insert(scan).inserted);
  const auto exported = mapper.exportMap();

  msg::OccupancyMap map;
  map.header().frame_id("map");
  map.resolution(exported.resolution);
  map.octree(exported.octree_binary);
  EXPECT_EQ(nodes::checkOccupancyMap(map, "map", box2d()), "");

  auto garbage = map;
  garbage.octree(std::vector<std::uint8_t>{'n', 'o', 't', ' ', 'a', 'n', ' ', 'o', 'c', 't', 'r', 'e', 'e'});
  EXPECT_NE(nodes::checkOccupancyMap(garbage, "map", box2d()).find("not a binary OctoMap"), std::string::npos);

  auto truncated = map;
  truncated.octree().resize(truncated.octree().size() - 3);
  EXPECT_NE(nodes::checkOccupancyMap(truncated, "map", box2d()), "");

  auto no_resolution = map;
  no_resolution.resolution(kNaN);
  EXPECT_NE(nodes::checkOccupancyMap(no_resolution, "map", box2d()).find("resolution"), std::string::npos);

  auto lidar = map;
  lidar.header().frame_id("lidar");
  EXPECT_NE(nodes::checkOccupancyMap(lidar, "map", box2d()).find("frame 'lidar'"), std::string::npos);
}

TEST(PlanarCloud, IgnoresNonFinitePoints) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<Eigen::Vector3f> scan = {{1, 0, 0}, {2, 1, 0}, {0, -3, 0}};
  EXPECT_TRUE(nodes::isPlanarCloud(scan));
  // "No return" beams of a planar scanner: NaN or infinite, possibly in z.
  scan.push_back({nan, nan, nan});
  scan.push_back({inf, 0, 0});
  scan.push_back({1, 1, -inf});
  EXPECT_TRUE(nodes::isPlanarCloud(scan));
  scan.push_back({1, 1, 0.25f});
  EXPECT_FALSE(nodes::isPlanarCloud(scan));
  EXPECT_TRUE(nodes::isPlanarCloud({}));
}

namespace {

msg::VehicleState goodState() {
  msg::VehicleState s;
  s.header().frame_id("map");
  s.position().x(3);
  s.position().y(3);
  s.heading(0.7);
  s.velocity().x(1.0);
  s.yaw_rate(0.1);
  return s;
}

planner::Scenario yard2d() {
  planner::Scenario s;
  s.dimensions = 2;
  s.bounds_min = {0, 0, 0};
  s.bounds_max = {40, 40, 0};
  return s;
}

msg::PlanRequest goodRequest() {
  msg::PlanRequest r;
  r.header().frame_id("map");
  r.request_id(1);
  r.planner("rrtstar");
  r.start().x(3);
  r.start().y(3);
  r.goal().x(36);
  r.goal().y(35);
  r.goal_radius(1.5);
  r.time_budget_s(1.0);
  return r;
}

}  // namespace

TEST(VehicleStateCheck, NamesTheFirstNonFiniteField) {
  EXPECT_EQ(nodes::checkVehicleState(goodState(), "map"), "");
  auto s = goodState();
  s.position().z(kNaN);
  EXPECT_EQ(nodes::checkVehicleState(s, "map"), "position.z is nan");
  s = goodState();
  s.heading(kInf);
  EXPECT_EQ(nodes::checkVehicleState(s, "map"), "heading is inf");
  s = goodState();
  s.velocity().y(-kInf);
  EXPECT_EQ(nodes::checkVehicleState(s, "map"), "velocity.y is -inf");
  s = goodState();
  s.yaw_rate(kNaN);
  EXPECT_EQ(nodes::checkVehicleState(s, "map"), "yaw_rate is nan");
  s = goodState();
  s.header().frame_id("odom");
  EXPECT_NE(nodes::checkVehicleState(s, "map").find("frame 'odom'"), std::string::npos);
  EXPECT_EQ(nodes::checkVehicleState(s, ""), "");
}

TEST(PathCheck, RefusesNonFiniteStatesAndEmptySolvedPaths) {
  msg::Path path;
  path.solved(true);
  EXPECT_EQ(nodes::checkPath(path), "solved, but it has no states");
  path.solved(false);
  EXPECT_EQ(nodes::checkPath(path), "");  // an unsolved answer carries no states
  path.solved(true);
  for (int i = 0; i < 4; ++i) {
    msg::PathState s;
    s.x(i);
    path.states().push_back(s);
  }
  EXPECT_EQ(nodes::checkPath(path), "");
  path.states()[3].y(kInf);
  EXPECT_EQ(nodes::checkPath(path), "state 3: y is inf");
}

TEST(PlanRequestCheck, RefusesCoordinatesOutsideTheBoundsAndBadNumbers) {
  const auto world = yard2d();
  EXPECT_EQ(nodes::checkPlanRequest(goodRequest(), world, "map"), "");
  auto r = goodRequest();
  r.goal().z(1e300);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "goal.z = 1e+300 is outside the planning bounds [0, 0] (a 2-D world)");
  r = goodRequest();
  r.start().x(kNaN);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "start.x = nan is outside the planning bounds [0, 40]");
  r = goodRequest();
  r.start().y(1e15);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "start.y = 1e+15 is outside the planning bounds [0, 40]");
  r = goodRequest();
  r.goal().x(-0.5);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "goal.x = -0.5 is outside the planning bounds [0, 40]");
  r = goodRequest();
  r.start().heading(kInf);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "start.heading is inf");
  r = goodRequest();
  r.goal_radius(1e300);
  EXPECT_NE(nodes::checkPlanRequest(r, world, "map").find("goal_radius = 1e+300 m, expected (0, 56.5685]"), std::string::npos)
      << nodes::checkPlanRequest(r, world, "map");
  r.goal_radius(0);
  EXPECT_NE(nodes::checkPlanRequest(r, world, "map").find("goal_radius = 0 m"), std::string::npos);
  r = goodRequest();
  r.time_budget_s(kInf);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "time_budget_s = inf s, expected a positive finite number of seconds");
  r = goodRequest();
  r.improve_for_s(-0.1);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "improve_for_s = -0.1 s, expected a finite number of seconds >= 0");
  r.improve_for_s(std::nan(""));
  EXPECT_NE(nodes::checkPlanRequest(r, world, "map").find("improve_for_s = nan s"), std::string::npos);
  r.improve_for_s(0.25);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "");
  r = goodRequest();
  r.header().frame_id("odom");
  EXPECT_NE(nodes::checkPlanRequest(r, world, "map").find("frame 'odom'"), std::string::npos);
  // A corner of the bounds is inside them; in 3-D, z is a coordinate like the others.
  r = goodRequest();
  r.goal().x(40);
  r.goal().y(40);
  EXPECT_EQ(nodes::checkPlanRequest(r, world, "map"), "");
  auto world3d = world;
  world3d.dimensions = 3;
  world3d.bounds_max.z() = 10;
  r.goal().z(5);
  EXPECT_EQ(nodes::checkPlanRequest(r, world3d, "map"), "");
  r.goal().z(10.5);
  EXPECT_EQ(nodes::checkPlanRequest(r, world3d, "map"), "goal.z = 10.5 is outside the planning bounds [0, 10]");
}
