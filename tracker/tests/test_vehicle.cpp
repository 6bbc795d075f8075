#include "ddsnav/tracker/vehicle.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace ddsnav::tracker;

namespace {
VehicleConfig unitConfig(int dims = 2) {
  VehicleConfig c;
  c.limits.v_max = 2.0;
  c.limits.omega_max = 1.0;
  c.limits.vz_max = 0.5;
  c.dimensions = dims;
  c.max_accel = c.max_yaw_accel = c.max_vertical_accel = std::numeric_limits<double>::infinity();
  return c;
}
}  // namespace

TEST(Vehicle, DrivesStraightAlongHeading) {
  VehicleState s0;
  s0.heading = std::numbers::pi / 2;
  UnicycleVehicle car(unitConfig(), s0);
  for (int i = 0; i < 10; ++i) car.step({1.0, 0.0, 0.0}, 0.1);
  EXPECT_NEAR(car.state().position.x(), 0.0, 1e-9);
  EXPECT_NEAR(car.state().position.y(), 1.0, 1e-9);
  EXPECT_NEAR(car.state().time, 1.0, 1e-9);
}

TEST(Vehicle, FullCircleReturnsToStart) {
  UnicycleVehicle car(unitConfig());
  // v = 1, omega = 1: a circle of radius 1 takes 2 pi seconds.
  const int steps = 628;
  const double dt = 2 * std::numbers::pi / steps;
  double max_dist = 0.0;
  for (int i = 0; i < steps; ++i) {
    car.step({1.0, 1.0, 0.0}, dt);
    max_dist = std::max(max_dist, car.state().position.norm());
  }
  EXPECT_NEAR(car.state().position.norm(), 0.0, 1e-9);
  EXPECT_NEAR(max_dist, 2.0, 1e-3);  // the diameter
}

TEST(Vehicle, CommandsAreSaturated) {
  UnicycleVehicle car(unitConfig(3));
  const auto c = car.saturate({10.0, -5.0, 3.0});
  EXPECT_DOUBLE_EQ(c.v, 2.0);
  EXPECT_DOUBLE_EQ(c.omega, -1.0);
  EXPECT_DOUBLE_EQ(c.vz, 0.5);
  EXPECT_DOUBLE_EQ(car.saturate({-1.0, 0, 0}).v, 0.0);  // no reversing
  car.step({10.0, 0.0, 3.0}, 1.0);
  EXPECT_NEAR(car.state().position.x(), 2.0, 1e-9);
  EXPECT_NEAR(car.state().position.z(), 0.5, 1e-9);
}

TEST(Vehicle, TwoDimensionalVehicleIgnoresVz) {
  UnicycleVehicle car(unitConfig(2));
  car.step({1.0, 0.0, 1.0}, 1.0);
  EXPECT_DOUBLE_EQ(car.state().position.z(), 0.0);
}

TEST(Vehicle, AccelerationLimited) {
  auto cfg = unitConfig();
  cfg.max_accel = 1.0;
  cfg.max_yaw_accel = 0.5;
  UnicycleVehicle car(cfg);
  car.step({2.0, 1.0, 0.0}, 0.5);
  EXPECT_NEAR(car.state().v, 0.5, 1e-12);
  EXPECT_NEAR(car.state().omega, 0.25, 1e-12);
}

TEST(Vehicle, HeadingWrapsAroundPi) {
  VehicleState s0;
  s0.heading = std::numbers::pi - 0.05;
  UnicycleVehicle car(unitConfig(), s0);
  car.step({0.0, 1.0, 0.0}, 0.1);
  EXPECT_NEAR(car.state().heading, -std::numbers::pi + 0.05, 1e-12);
  EXPECT_NEAR(wrapAngle(3 * std::numbers::pi), std::numbers::pi, 1e-12);
  EXPECT_NEAR(wrapAngle(-std::numbers::pi), std::numbers::pi, 1e-12);
}

TEST(Vehicle, NoiseIsSeededAndBounded) {
  auto cfg = unitConfig();
  cfg.noise = VehicleNoise::nominal(7);
  UnicycleVehicle a(cfg), b(cfg);
  auto clean = unitConfig();
  UnicycleVehicle ideal(clean);
  for (int i = 0; i < 200; ++i) {
    a.step({1.0, 0.2, 0}, 0.05);
    b.step({1.0, 0.2, 0}, 0.05);
    ideal.step({1.0, 0.2, 0}, 0.05);
  }
  EXPECT_EQ(a.state().position, b.state().position);          // same seed, same run
  EXPECT_GT((a.state().position - ideal.state().position).norm(), 1e-4);  // the noise did something
  EXPECT_LT((a.state().position - ideal.state().position).norm(), 2.0);   // ... but not absurdly much
}

TEST(Vehicle, RejectsBadInput) {
  auto cfg = unitConfig();
  cfg.limits.v_max = 0.0;
  EXPECT_THROW(UnicycleVehicle{cfg}, std::invalid_argument);
  UnicycleVehicle car(unitConfig());
  EXPECT_THROW(car.step({NAN, 0, 0}, 0.1), std::invalid_argument);
  EXPECT_THROW(car.step({1, 0, 0}, 0.0), std::invalid_argument);
  EXPECT_THROW(car.step({1, 0, 0}, INFINITY), std::invalid_argument);
}
