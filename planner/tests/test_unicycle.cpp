// Forward extending region geometry, checked against values worked out by hand.
#include "ddsnav/planner/unicycle.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

namespace ddsnav::planner {
namespace {

constexpr double kPi = std::numbers::pi;

// GART paper's vehicle: v = 5 m/s, omega = 0.2 pi rad/s, dt = 1 s -> reach 5 m, max turn 0.2 pi.
ForwardRegion gartRegion(int dims = 2) {
  VehicleLimits limits;
  limits.v_max = 5.0;
  limits.omega_max = 0.2 * kPi;
  limits.vz_max = 2.0;
  limits.dt = 1.0;
  return forwardRegion(limits, dims);
}

// One disc obstacle of radius 1 at (10, 0) in a 20 x 20 box, point robot.
class DiscWorld : public CollisionWorld {
 public:
  int dimensions() const override { return 2; }
  Vec3 boundsMin() const override { return {-10, -10, 0}; }
  Vec3 boundsMax() const override { return {20, 10, 0}; }
  double robotRadius() const override { return 0.0; }
  bool isFree(const Vec3& p) const override {
    countCheck();
    return (p - Vec3(10, 0, 0)).norm() > 1.0 && p.x() >= -10 && p.x() <= 20 && std::abs(p.y()) <= 10;
  }
  double clearance(const Vec3& p) const override { return (p - Vec3(10, 0, 0)).norm() - 1.0; }
  std::vector<NearbyObstacle> obstaclesNear(const Vec3&, double) const override { return {}; }
};

TEST(Unicycle, RegionFromLimits) {
  const ForwardRegion r = gartRegion();
  EXPECT_DOUBLE_EQ(r.reach, 5.0);
  EXPECT_DOUBLE_EQ(r.max_turn, 0.2 * kPi);
  EXPECT_DOUBLE_EQ(r.max_climb, 0.0);
  EXPECT_DOUBLE_EQ(gartRegion(3).max_climb, 2.0);
  VehicleLimits bad;
  bad.v_max = 0.0;
  bad.omega_max = 1.0;
  EXPECT_THROW(forwardRegion(bad, 2), std::invalid_argument);
  bad.v_max = std::nan("");
  EXPECT_THROW(forwardRegion(bad, 2), std::invalid_argument);
}

TEST(Unicycle, WrapAngle) {
  EXPECT_NEAR(wrapAngle(3 * kPi / 2), -kPi / 2, 1e-12);
  EXPECT_NEAR(wrapAngle(-3 * kPi / 2), kPi / 2, 1e-12);
  EXPECT_NEAR(wrapAngle(-kPi), kPi, 1e-12);
  EXPECT_NEAR(wrapAngle(0.3), 0.3, 1e-15);
}

// wrapAngle's shortcut inside (-2 pi, 2 pi) gives exactly std::remainder's value, the boundaries included.
TEST(Unicycle, WrapAngleEqualsRemainderExactly) {
  const auto reference = [](double a) {
    a = std::remainder(a, 2.0 * kPi);
    return a <= -kPi ? a + 2.0 * kPi : a;
  };
  std::vector<double> values = {0.0, -0.0, kPi, -kPi, 2 * kPi, -2 * kPi, 3 * kPi, -3 * kPi, 1e-300, 1e9, -1e9};
  for (double v : {kPi, 2 * kPi}) {
    for (double s : {1.0, -1.0}) {
      values.push_back(std::nextafter(s * v, 0.0));
      values.push_back(std::nextafter(s * v, s * 10.0));
    }
  }
  for (int i = -20000; i <= 20000; ++i) values.push_back(i * 7.0 * kPi / 20000.0 + 1e-7 * i);
  for (double v : values) EXPECT_EQ(wrapAngle(v), reference(v)) << v;
}

TEST(Unicycle, InsideRegion2D) {
  const ForwardRegion r = gartRegion();
  const State parent{Vec3(0, 0, 0), 0.0};
  EXPECT_TRUE(inForwardRegion(parent, {3, 0, 0}, r));
  EXPECT_TRUE(inForwardRegion(parent, {5, 0, 0}, r));                                   // on the arc
  EXPECT_FALSE(inForwardRegion(parent, {5.01, 0, 0}, r));                               // beyond reach
  EXPECT_TRUE(inForwardRegion(parent, {4 * std::cos(0.6), 4 * std::sin(0.6), 0}, r));   // 0.6 < 0.628
  EXPECT_FALSE(inForwardRegion(parent, {4 * std::cos(0.7), -4 * std::sin(0.7), 0}, r));  // 0.7 > 0.628
  EXPECT_FALSE(inForwardRegion(parent, {-1, 0, 0}, r));                                 // behind
  EXPECT_TRUE(inForwardRegion(parent, {0, 0, 0}, r));                                   // no motion
  // Across the +-pi seam: heading pi - 0.1, target direction -pi + 0.2 is a turn of 0.3.
  const State west{Vec3(0, 0, 0), kPi - 0.1};
  EXPECT_TRUE(inForwardRegion(west, {2 * std::cos(-kPi + 0.2), 2 * std::sin(-kPi + 0.2), 0}, r));
  EXPECT_FALSE(inForwardRegion(west, {2 * std::cos(-kPi + 0.8), 2 * std::sin(-kPi + 0.8), 0}, r));
}

TEST(Unicycle, InsideRegion3D) {
  const ForwardRegion r = gartRegion(3);
  const State parent{Vec3(0, 0, 10), 0.0};
  EXPECT_TRUE(inForwardRegion(parent, {3, 0, 11.5}, r));
  EXPECT_FALSE(inForwardRegion(parent, {3, 0, 12.5}, r));  // climbs 2.5 > 2
  EXPECT_TRUE(inForwardRegion(parent, {0, 0, 8.0}, r));    // pure descent of 2: no horizontal turn
  // Horizontal length is what is limited: 4 m across and 2 m up is inside although its 3-D length > 4.
  EXPECT_TRUE(inForwardRegion(parent, {4.9, 0, 12.0}, r));
}

TEST(Unicycle, SteerClampsTurnAndLength) {
  const ForwardRegion r = gartRegion();
  const State parent{Vec3(0, 0, 0), 0.0};
  // Target straight left: turn clamps to 0.2 pi, length to 5.
  const State s = steerUnicycle(parent, {0, 10, 0}, r);
  EXPECT_NEAR(s.position.x(), 5 * std::cos(0.2 * kPi), 1e-12);  // 4.0451
  EXPECT_NEAR(s.position.y(), 5 * std::sin(0.2 * kPi), 1e-12);  // 2.9389
  EXPECT_NEAR(s.heading, 0.2 * kPi, 1e-12);
  EXPECT_TRUE(inForwardRegion(parent, s.position, r));
  // Target inside: reached exactly.
  const State t = steerUnicycle(parent, {2, 0.5, 0}, r);
  EXPECT_EQ(t.position, Vec3(2, 0.5, 0));
  EXPECT_NEAR(t.heading, std::atan2(0.5, 2), 1e-15);
  // Far ahead: shortened to the reach.
  const State u = steerUnicycle(parent, {100, 0, 0}, r);
  EXPECT_NEAR(u.position.x(), 5.0, 1e-12);
  EXPECT_NEAR(u.position.y(), 0.0, 1e-12);
}

TEST(Unicycle, SteerClimbs3D) {
  const ForwardRegion r = gartRegion(3);
  const State parent{Vec3(0, 0, 0), 0.0};
  // 10 m ahead and 10 m up: half the horizontal distance -> half the climb (5 m), clamped to 2.
  const State s = steerUnicycle(parent, {10, 0, 10}, r);
  EXPECT_NEAR((s.position - Vec3(5, 0, 2)).norm(), 0.0, 1e-12);
  // 10 m ahead and 2 m up: proportional climb 1 m, within the limit.
  const State t = steerUnicycle(parent, {10, 0, 2}, r);
  EXPECT_NEAR((t.position - Vec3(5, 0, 1)).norm(), 0.0, 1e-12);
}

TEST(Unicycle, DriveTurnsAndDrives) {
  const ForwardRegion r = gartRegion();
  const State parent{Vec3(1, 1, 0), kPi / 2};
  const State c = driveUnicycle(parent, -0.5, 2.0, 0.0, r);
  EXPECT_NEAR(c.position.x(), 1 + 2 * std::cos(kPi / 2 - 0.5), 1e-12);
  EXPECT_NEAR(c.position.y(), 1 + 2 * std::sin(kPi / 2 - 0.5), 1e-12);
  EXPECT_NEAR(c.heading, kPi / 2 - 0.5, 1e-12);
  // An over-large turn is clamped.
  EXPECT_NEAR(driveUnicycle(parent, 3.0, 1.0, 0.0, r).heading, kPi / 2 + 0.2 * kPi, 1e-12);
}

TEST(Unicycle, PathCheck) {
  const ForwardRegion r = gartRegion();
  State a{Vec3(0, 0, 0), 0.0};
  State b{Vec3(4, 0, 0), 0.0};
  State c{Vec3(4 + 4 * std::cos(0.5), 4 * std::sin(0.5), 0), 0.5};
  EXPECT_TRUE(checkUnicyclePath({a, b, c}, r).ok);

  // The second edge turns 0.7 rad from the first: edge 1 is reported.
  State c_sharp{Vec3(4 + 4 * std::cos(0.7), 4 * std::sin(0.7), 0), 0.7};
  PathCheck bad_turn = checkUnicyclePath({a, b, c_sharp}, r);
  EXPECT_FALSE(bad_turn.ok);
  EXPECT_EQ(bad_turn.edge, 1);

  // The first edge is measured from the start heading: start facing +y, edge along +x is a turn of pi/2.
  State a_north{Vec3(0, 0, 0), kPi / 2};
  EXPECT_EQ(checkUnicyclePath({a_north, b}, r).edge, 0);

  // Too long.
  State far{Vec3(6, 0, 0), 0.0};
  EXPECT_EQ(checkUnicyclePath({a, far}, r).edge, 0);

  // Stored heading inconsistent with the edge.
  State b_wrong{Vec3(4, 0, 0), 0.3};
  EXPECT_EQ(checkUnicyclePath({a, b_wrong}, r).edge, 0);

  // Collision: 5 m along y = 0 from x = 6 crosses the disc at (10, 0).
  DiscWorld world;
  State d{Vec3(6, 0, 0), 0.0};
  State e{Vec3(11.5, 0, 0), 0.0};
  EXPECT_TRUE(checkUnicyclePath({a, b, d}, r, &world).ok);
  PathCheck hit = checkUnicyclePath({a, b, d, State{Vec3(8, 0, 0), 0.0}, State{Vec3(11.5 - 0.4, 0, 0), 0.0}, e}, r,
                                    &world);
  EXPECT_FALSE(hit.ok);
  EXPECT_EQ(hit.edge, 3);
  EXPECT_FALSE(checkUnicyclePath({}, r).ok);
}

}  // namespace
}  // namespace ddsnav::planner
