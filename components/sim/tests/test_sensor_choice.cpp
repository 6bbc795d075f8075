// The simulator's default sensor for scenarios of very different scales, and its refusal of blind sensors.
#include "ddsnav/sim/sensor_choice.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace ddsnav::sim {
namespace {

const std::string kScenarios = std::string(DDSNAV_SOURCE_DIR) + "/configs/scenarios/";

// A square 2-D world of side `side` with a vehicle, nothing in it.
planner::Scenario square(double side, double v_max, double omega_max, int dimensions = 2) {
  planner::Scenario s;
  s.name = "square";
  s.dimensions = dimensions;
  s.bounds_min = {0, 0, 0};
  s.bounds_max = {side, side, dimensions == 3 ? 50.0 : 0.0};
  s.robot_radius = 0.3;
  s.start = {1, 1, dimensions == 3 ? 5.0 : 0.0};
  s.goal = {side - 1, side - 1, s.start.z()};
  s.goal_radius = 1.0;
  planner::VehicleLimits v;
  v.v_max = v_max;
  v.omega_max = omega_max;
  s.vehicle = v;
  return s;
}

std::string errorOf(const planner::Scenario& s, const SensorRequest& r) {
  try {
    chooseSensor(s, r);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(SensorChoice, SmallYardGetsAShortRangeScanner) {
  // 20 m yard, 1 m/s, 1 rad/s: reaction 10 * 1 + 2 * 1 / 1 = 12 m, extent / 10 = 2 m.
  const auto choice = chooseSensor(square(20, 1.0, 1.0));
  EXPECT_EQ(choice.kind, SensorKind::Scanner);
  EXPECT_DOUBLE_EQ(choice.config.max_range, 12.0);
  EXPECT_DOUBLE_EQ(choice.config.horizontal_fov_deg, 360.0);
  EXPECT_EQ(choice.config.rings, 1);
  EXPECT_EQ(choice.config.columns, 720);
}

TEST(SensorChoice, TwoKilometreCoastGetsAForwardSonar) {
  // 2 km coast, 2 m/s, 0.15 rad/s: reaction 20 + 26.7 m, extent / 10 = 200 m, capped at 200 m.
  const auto choice = chooseSensor(square(2000, 2.0, 0.15));
  EXPECT_EQ(choice.kind, SensorKind::Sonar);
  EXPECT_DOUBLE_EQ(choice.config.max_range, 200.0);
  EXPECT_DOUBLE_EQ(choice.config.horizontal_fov_deg, 130.0);
  EXPECT_EQ(choice.config.columns, 261);  // every 0.5 degrees, both edges included
  EXPECT_EQ(choice.config.rings, 1);
  // Just under sea scale: a scanner whose range is the extent share.
  const auto bay = chooseSensor(square(499, 2.0, 0.15));
  EXPECT_EQ(bay.kind, SensorKind::Scanner);
  EXPECT_NEAR(bay.config.max_range, 49.9, 1e-9);
}

TEST(SensorChoice, RangeNeverExceedsTheWorldDiagonal) {
  // A fast vehicle in a 5 m room: 10 s at 10 m/s would be 100 m.
  const auto choice = chooseSensor(square(5, 10.0, 1.0));
  EXPECT_NEAR(choice.config.max_range, std::hypot(5.0, 5.0), 1e-9);
}

TEST(SensorChoice, ThreeDimensionalWorldGetsALidar) {
  const auto choice = chooseSensor(square(110, 5.0, 0.628, 3));
  EXPECT_EQ(choice.kind, SensorKind::Lidar);
  EXPECT_EQ(choice.config.rings, 16);
  EXPECT_EQ(choice.config.columns, 512);
  EXPECT_NEAR(choice.config.max_range, 50.0 + 2.0 * 5.0 / 0.628, 1e-9);
}

TEST(SensorChoice, ShippedScenariosGetTheDocumentedSensor) {
  struct Case {
    const char* file;
    SensorKind kind;
    double range;
  };
  for (const Case& c : {Case{"demo_2d.yaml", SensorKind::Scanner, 20.0 + 4.0 / 0.628},
                        Case{"gart_terrain_3d.yaml", SensorKind::Lidar, 50.0 + 10.0 / 0.6283185307},
                        Case{"auv_coastal.yaml", SensorKind::Sonar, 200.0},
                        Case{"stunnel_small_1.0.yaml", SensorKind::Scanner, 5.0 + 1.0}}) {
    const auto world = planner::loadScenario(kScenarios + c.file);
    const auto choice = chooseSensor(world);
    EXPECT_EQ(choice.kind, c.kind) << c.file;
    EXPECT_NEAR(choice.config.max_range, c.range, 1e-6) << c.file;
  }
}

TEST(SensorChoice, AuvCoastSonarSeesTheShoreOnTheWay) {
  // The 30 m scanner the simulator used to mount saw nothing at sea: on the straight line from start to
  // goal there must be poses where the default sonar returns points.
  const auto world = planner::loadScenario(kScenarios + "auv_coastal.yaml");
  RangeSensor sensor(world, chooseSensor(world).config);
  const Eigen::Vector3d along = world.goal - world.start;
  const double heading = std::atan2(along.y(), along.x());
  std::size_t poses_with_points = 0;
  for (int i = 0; i <= 20; ++i) {
    const auto cloud = sensor.scan({world.start + along * (i / 20.0), heading});
    poses_with_points += !cloud.points.empty();
  }
  EXPECT_GE(poses_with_points, 5u);
}

TEST(SensorChoice, UserOverridesWin) {
  SensorRequest r;
  r.kind = SensorKind::Sonar;
  r.max_range = 35.0;
  r.fov_deg = 90.0;
  const auto choice = chooseSensor(square(20, 1.0, 1.0), r);
  EXPECT_EQ(choice.kind, SensorKind::Sonar);
  EXPECT_DOUBLE_EQ(choice.config.max_range, 35.0);
  EXPECT_DOUBLE_EQ(choice.config.horizontal_fov_deg, 90.0);
  EXPECT_EQ(choice.config.columns, 181);
  EXPECT_NE(choice.summary.find("range 35.0 m (set)"), std::string::npos) << choice.summary;
  // A 3-D sonar is a fan of rings.
  const auto fan = chooseSensor(square(110, 5.0, 0.6, 3), r);
  EXPECT_EQ(fan.config.rings, 8);
  EXPECT_DOUBLE_EQ(fan.config.vertical_max_deg - fan.config.vertical_min_deg, 20.0);
}

TEST(SensorChoice, BlindOrMismatchedSensorsAreRefusedByName) {
  const auto yard = square(20, 1.0, 1.0);
  SensorRequest zero_range;
  zero_range.max_range = 0.0;
  EXPECT_NE(errorOf(yard, zero_range).find("max_range"), std::string::npos);
  SensorRequest nan_range;
  nan_range.max_range = std::nan("");
  EXPECT_NE(errorOf(yard, nan_range).find("max_range"), std::string::npos);
  SensorRequest empty_fov;
  empty_fov.fov_deg = 0.0;
  EXPECT_NE(errorOf(yard, empty_fov).find("fov_deg"), std::string::npos);
  SensorRequest wide_fov;
  wide_fov.fov_deg = 400.0;
  EXPECT_NE(errorOf(yard, wide_fov).find("fov_deg"), std::string::npos);
  SensorRequest no_beams;
  no_beams.beams = 0;
  EXPECT_NE(errorOf(yard, no_beams).find("beams"), std::string::npos);
  SensorRequest lidar;
  lidar.kind = SensorKind::Lidar;
  EXPECT_NE(errorOf(yard, lidar).find("2-D"), std::string::npos);
  SensorRequest rings;
  rings.rings = 4;
  EXPECT_NE(errorOf(yard, rings).find("rings"), std::string::npos);
  SensorRequest scanner;
  scanner.kind = SensorKind::Scanner;
  EXPECT_NE(errorOf(square(20, 1.0, 1.0, 3), scanner).find("3-D"), std::string::npos);
  EXPECT_THROW(parseSensorKind("radar"), std::invalid_argument);
  EXPECT_EQ(parseSensorKind("auto"), std::nullopt);
  EXPECT_EQ(parseSensorKind("sonar"), SensorKind::Sonar);
}

// The lidar's fan covers the vehicle's steepest climb: the planner blocks what the fan cannot see near the vehicle.
TEST(SensorChoice, TheLidarsFanCoversTheVehiclesSteepestClimb) {
  auto steep = square(60, 3.0, 0.4, 3);
  steep.vehicle->vz_max = 2.0;  // 33.7 degrees
  const auto choice = chooseSensor(steep);
  EXPECT_DOUBLE_EQ(choice.config.vertical_max_deg, 37.0);
  EXPECT_DOUBLE_EQ(choice.config.vertical_min_deg, -37.0);
  EXPECT_EQ(choice.config.rings, 23);  // 16 would be 4.9 degrees apart: 3.4 at most
  auto gentle = square(60, 5.0, 0.6, 3);
  gentle.vehicle->vz_max = 0.5;  // 5.7 degrees: the +-15 degree fan of 16 rings
  EXPECT_DOUBLE_EQ(chooseSensor(gentle).config.vertical_max_deg, 15.0);
  EXPECT_EQ(chooseSensor(gentle).config.rings, 16);
  auto climber = square(60, 5.0, 0.6, 3);
  climber.vehicle->vz_max = 2.0;  // 21.8 degrees: +-25 degrees, 16 rings 3.3 degrees apart
  EXPECT_DOUBLE_EQ(chooseSensor(climber).config.vertical_max_deg, 25.0);
  EXPECT_EQ(chooseSensor(climber).config.rings, 16);
  auto rocket = square(60, 1.0, 0.6, 3);
  rocket.vehicle->vz_max = 10.0;  // 84 degrees: capped at +-45
  EXPECT_DOUBLE_EQ(chooseSensor(rocket).config.vertical_max_deg, 45.0);
  EXPECT_EQ(chooseSensor(rocket).config.rings, 24);
  // What the user sets wins; the rings follow the span they set.
  SensorRequest request;
  request.vertical_min_deg = -10.0;
  request.vertical_max_deg = 10.0;
  const auto set = chooseSensor(steep, request);
  EXPECT_DOUBLE_EQ(set.config.vertical_max_deg, 10.0);
  EXPECT_EQ(set.config.rings, 16);
}

}  // namespace
}  // namespace ddsnav::sim
