// GART: control-effort metric and the bidirectional potential field events on hand-built disc worlds.
#include "ddsnav/planner/gart.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace ddsnav::planner {
namespace {

constexpr double kPi = std::numbers::pi;

// Discs in a 2-D box, point robot: exact contact information for obstaclesNear.
class DiscWorld : public CollisionWorld {
 public:
  struct Disc {
    Vec3 center;
    double radius;
  };
  explicit DiscWorld(std::vector<Disc> discs) : discs_(std::move(discs)) {}
  int dimensions() const override { return 2; }
  Vec3 boundsMin() const override { return {-50, -50, 0}; }
  Vec3 boundsMax() const override { return {50, 50, 0}; }
  double robotRadius() const override { return 0.0; }
  bool isFree(const Vec3& p) const override {
    countCheck();
    if (std::abs(p.x()) > 50 || std::abs(p.y()) > 50) return false;
    return clearance(p) > 0.0;
  }
  double clearance(const Vec3& p) const override {
    double c = 1e9;
    for (const Disc& d : discs_) c = std::min(c, (p - d.center).norm() - d.radius);
    return c;
  }
  std::vector<NearbyObstacle> obstaclesNear(const Vec3& p, double range) const override {
    std::vector<NearbyObstacle> out;
    for (std::size_t i = 0; i < discs_.size(); ++i) {
      const Disc& d = discs_[i];
      const double distance = (p - d.center).norm() - d.radius;
      if (distance > range) continue;
      NearbyObstacle o;
      o.id = static_cast<int>(i);
      o.nearest_point = d.center + (p - d.center).normalized() * d.radius;
      o.distance = std::max(0.0, distance);
      out.push_back(o);
    }
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.distance < b.distance; });
    return out;
  }

 private:
  std::vector<Disc> discs_;
};

// The GART paper's vehicle: reach J = 5 m, theta_m = 0.2 pi.
ForwardRegion region() {
  VehicleLimits limits;
  limits.v_max = 5.0;
  limits.omega_max = 0.2 * kPi;
  limits.dt = 1.0;
  return forwardRegion(limits, 2);
}

// Goal attraction off, so each test sees only the obstacle part of the field.
GartOptions noGoalPull() {
  GartOptions o;
  o.goal_gain = 0.0;
  return o;
}

const State kParent{Vec3(0, 0, 0), 0.0};

TEST(GartEffort, HeadingAndDistance) {
  const ForwardRegion r = region();
  // Straight ahead 5 m: no turn, one reach -> 1.
  EXPECT_NEAR(gartControlEffort(kParent, {5, 0, 0}, r, 1.0), 1.0, 1e-12);
  // Half the maximum turn at 2.5 m: 0.5 + 0.5.
  const double a = 0.1 * kPi;
  EXPECT_NEAR(gartControlEffort(kParent, {2.5 * std::cos(a), 2.5 * std::sin(a), 0}, r, 1.0), 1.0, 1e-12);
  // Outside the max turn: not a feasible parent.
  EXPECT_TRUE(std::isinf(gartControlEffort(kParent, {0, 3, 0}, r, 1.0)));
  // A well-aligned far node beats a badly aligned near one with turn weight 2.
  const double near_but_turned = gartControlEffort(kParent, {std::cos(0.6), std::sin(0.6), 0}, r, 2.0);
  const double far_but_straight = gartControlEffort(kParent, {2.5, 0, 0}, r, 2.0);
  EXPECT_LT(far_but_straight, near_but_turned);
}

// No obstacle within the detection range: the projected sample is kept as it is.
TEST(GartRedistribute, FreeSampleIsProjected) {
  DiscWorld world({{Vec3(30, 30, 0), 1.0}});
  const auto out = gartRedistribute(kParent, {20, 0, 0}, {40, 0, 0}, world, region(), noGoalPull());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_FALSE(out[0].from_collision);
  EXPECT_EQ(out[0].field, GartEvent::kFree);
  EXPECT_NEAR((out[0].state.position - Vec3(5, 0, 0)).norm(), 0.0, 1e-12);
}

// Event 1: the sample straight ahead is blocked by a disc at (4, 0), r = 1. Turning in steps of
// theta_m / 4 from 0, the first free full-reach edge on each side is at +-0.1 pi (the line at angle a
// passes the centre at 4 sin a: 0.618 < 1 at 0.05 pi, 1.236 > 1 at 0.1 pi). Each candidate has one obstacle
// in range, so event 3's repulsion pushes it away from the disc before it is projected back into R+.
TEST(GartRedistribute, Event1GivesTwoFreeCandidatesRepulsed) {
  DiscWorld world({{Vec3(4, 0, 0), 1.0}});
  const ForwardRegion r = region();
  const GartOptions options = noGoalPull();
  const auto out = gartRedistribute(kParent, {10, 0, 0}, {40, 0, 0}, world, r, options);
  ASSERT_EQ(out.size(), 2u);
  int left = 0, right = 0;
  for (const GartCandidate& c : out) {
    EXPECT_TRUE(c.from_collision);
    EXPECT_TRUE(inForwardRegion(kParent, c.state.position, r));
    EXPECT_TRUE(world.isSegmentFree(kParent.position, c.state.position));
    EXPECT_EQ(c.field, GartEvent::kRepulsion);
    EXPECT_TRUE(c.redistributed);
    (c.state.position.y() > 0 ? left : right)++;

    // By hand: raw a = 5 (cos 0.1pi, +-sin 0.1pi); margin node O = c + (a - c)/|a - c|; push k2 / |a - O|
    // along (a - O), k2 = 0.05 * 5^2; then steer from the parent towards a + push.
    const double side = c.state.position.y() > 0 ? 1.0 : -1.0;
    const Vec3 a(5 * std::cos(0.1 * kPi), side * 5 * std::sin(0.1 * kPi), 0);
    const Vec3 centre(4, 0, 0);
    const Vec3 margin = centre + (a - centre).normalized();
    const double distance = (a - margin).norm();
    const Vec3 pushed = a + (a - margin).normalized() * std::min(1.25 / distance, 2.5);
    const State expected = steerUnicycle(kParent, pushed, r);
    EXPECT_NEAR((c.state.position - expected.position).norm(), 0.0, 1e-9);
    // Repulsed: farther from the obstacle than the raw candidate.
    EXPECT_GT(world.clearance(c.state.position), world.clearance(a));
  }
  EXPECT_EQ(left, 1);
  EXPECT_EQ(right, 1);
}

// Event 2: two discs leave a 1 m gap around y = 0 at x = 5. A free sample at (3, 0.8) sees both within
// the detection range and is attracted to the centroid of their nearest margin nodes: into the gap.
TEST(GartRedistribute, Event2AttractsIntoTheGap) {
  DiscWorld world({{Vec3(5, 2, 0), 1.5}, {Vec3(5, -2, 0), 1.5}});
  const ForwardRegion r = region();
  const Vec3 sample(3, 0.8, 0);
  const auto out = gartRedistribute(kParent, sample, {40, 0, 0}, world, r, noGoalPull());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_FALSE(out[0].from_collision);
  EXPECT_EQ(out[0].field, GartEvent::kAttraction);
  const Vec3 oa = Vec3(5, 2, 0) + (sample - Vec3(5, 2, 0)).normalized() * 1.5;    // (3.714, 1.228)
  const Vec3 ob = Vec3(5, -2, 0) + (sample - Vec3(5, -2, 0)).normalized() * 1.5;  // (4.128, -0.779)
  const Vec3 centroid = (oa + ob) / 2.0;                                           // (3.921, 0.225)
  EXPECT_NEAR((out[0].state.position - centroid).norm(), 0.0, 1e-9);
  // Attraction: it moved towards the gap's centre line and towards the gap itself (centre (5, 0)),
  // i.e. closer to the obstacles rather than away from them as APF repulsion would.
  EXPECT_LT(std::abs(out[0].state.position.y()), std::abs(sample.y()));
  EXPECT_LT((out[0].state.position - Vec3(5, 0, 0)).norm(), (sample - Vec3(5, 0, 0)).norm());
  EXPECT_TRUE(world.isSegmentFree(kParent.position, out[0].state.position));

  const GartForce f = gartObstacleForce(sample, world, r, noGoalPull());
  EXPECT_EQ(f.obstacles, 2);
  EXPECT_GT(f.displacement.dot(centroid - sample), 0.0);
}

// Event 3: the same sample next to a single disc is pushed away from it (attraction reversed).
TEST(GartRedistribute, Event3RepelsFromSingleObstacle) {
  DiscWorld world({{Vec3(5, 2, 0), 1.5}});
  const ForwardRegion r = region();
  const Vec3 sample(3, 0.8, 0);
  const GartForce f = gartObstacleForce(sample, world, r, noGoalPull());
  EXPECT_EQ(f.event, GartEvent::kRepulsion);
  EXPECT_EQ(f.obstacles, 1);
  const Vec3 margin = Vec3(5, 2, 0) + (sample - Vec3(5, 2, 0)).normalized() * 1.5;
  // Pointing away from the margin node, magnitude k2 / d = 1.25 / 0.832.
  EXPECT_NEAR(f.displacement.normalized().dot((sample - margin).normalized()), 1.0, 1e-12);
  EXPECT_NEAR(f.displacement.norm(), 1.25 / (sample - margin).norm(), 1e-12);
  const auto out = gartRedistribute(kParent, sample, {40, 0, 0}, world, r, noGoalPull());
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].field, GartEvent::kRepulsion);
  EXPECT_GT(world.clearance(out[0].state.position), world.clearance(sample));
}

// Margin nodes closer than the robot's diameter leave no passable gap: the two overlapping discs are one
// obstacle seen from (2, 0) (nearest points (5.2, 2.4) and (5.44, 2.95), 0.6 m apart < 2 * 0.5 m), so
// this is event 3 (repulsion), not event 2.
TEST(GartRedistribute, TouchingPiecesCountAsOneObstacle) {
  class FatDiscWorld : public DiscWorld {
   public:
    using DiscWorld::DiscWorld;
    double robotRadius() const override { return 0.5; }
  } world({{Vec3(6, 3, 0), 1.0}, {Vec3(6.2, 3.6, 0), 1.0}});
  const GartForce f = gartObstacleForce({2, 0, 0}, world, region(), noGoalPull());
  EXPECT_EQ(f.obstacles, 1);
  EXPECT_EQ(f.event, GartEvent::kRepulsion);
  // The same discs far apart are two obstacles.
  DiscWorld apart({{Vec3(6, 3, 0), 1.0}, {Vec3(6, -3, 0), 1.0}});
  EXPECT_EQ(gartObstacleForce({2, 0, 0}, apart, region(), noGoalPull()).obstacles, 2);
}

// Goal attraction alone (no obstacles in range) pulls the projected sample towards the goal.
TEST(GartRedistribute, GoalAttraction) {
  DiscWorld world({{Vec3(30, 30, 0), 1.0}});
  GartOptions options;  // goal_gain 0.2 -> 1 m step
  const auto out = gartRedistribute(kParent, {3, 0, 0}, {3, 10, 0}, world, region(), options);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_TRUE(out[0].redistributed);
  EXPECT_NEAR((out[0].state.position - Vec3(3, 1, 0)).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace ddsnav::planner

