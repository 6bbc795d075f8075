#include "ddsnav/tracker/smoother.hpp"

#include "test_worlds.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

using namespace ddsnav::tracker;
using ddsnav::planner::Vec3;
using ddsnav::tracker::testing::pathOf;
using ddsnav::tracker::testing::scenario2d;

namespace {

ddsnav::planner::VehicleLimits limits(double v = 1.0, double w = 1.0, double vz = 0.0) {
  ddsnav::planner::VehicleLimits l;
  l.v_max = v;
  l.omega_max = w;
  l.vz_max = vz;
  return l;
}

// Checks every sample against the limits and the world; returns how many samples were checked.
void expectDrivable(const Trajectory& t, const ddsnav::planner::CollisionWorld& world,
                    const ddsnav::planner::VehicleLimits& l, const SmootherConfig& cfg) {
  ASSERT_GE(t.samples.size(), 2u);
  const double tol = 1e-9;
  for (std::size_t i = 0; i < t.samples.size(); ++i) {
    const auto& s = t.samples[i];
    EXPECT_TRUE(world.isFree(s.position)) << "sample " << i << " in collision";
    EXPECT_LE(s.speed, l.v_max + tol) << "sample " << i;
    EXPECT_GE(s.speed, 0.0) << "sample " << i;
    EXPECT_LE(std::abs(s.yaw_rate), l.omega_max + tol) << "sample " << i;
    EXPECT_LE(std::abs(s.speed * s.curvature), l.omega_max * (1 + 1e-6) + tol) << "sample " << i;
    if (t.dimensions == 3) {
      EXPECT_LE(std::abs(s.vz), l.vz_max + tol) << "sample " << i;
    }
    if (i > 0) {
      const auto& p = t.samples[i - 1];
      const double dt = s.time - p.time;
      EXPECT_GT(dt, 0.0);
      EXPECT_LE(dt, cfg.sample_dt + 1e-9);
      EXPECT_LE(std::abs(s.heading - p.heading), l.omega_max * dt + tol) << "heading jump at sample " << i;
      // Positions move no faster than the limits allow.
      EXPECT_LE((s.position - p.position).head<2>().norm(), l.v_max * dt + 1e-6) << "sample " << i;
    }
  }
  EXPECT_EQ(t.report.samples_in_collision, 0u);
  EXPECT_NEAR(t.samples.front().speed, 0.0, 1e-12);
  EXPECT_NEAR(t.samples.back().speed, 0.0, 1e-12);
}

}  // namespace

TEST(Smoother, StraightLineStaysStraight) {
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig cfg;
  auto t = smoothPath(pathOf({{1, 5, 0}, {4, 5, 0}, {7, 5, 0}, {12, 5, 0}}), *world, limits(), cfg);
  EXPECT_EQ(t.report.shortcut_waypoints, 2u);
  for (const auto& s : t.samples) {
    EXPECT_NEAR(s.position.y(), 5.0, 1e-9);
    EXPECT_NEAR(s.heading, 0.0, 1e-9);
    EXPECT_NEAR(s.curvature, 0.0, 1e-9);
  }
  EXPECT_NEAR(t.report.length, 11.0, 1e-6);
  EXPECT_NEAR(t.samples.back().position.x(), 12.0, 1e-12);
  // Accelerating at 1 m/s^2 to 0.85 m/s and back: duration = L / v + v / a.
  EXPECT_NEAR(t.report.duration, 11.0 / 0.85 + 0.85 / 1.0, 0.05);
  expectDrivable(t, *world, limits(), cfg);
}

TEST(Smoother, RightAngleGetsBoundedCurvatureArc) {
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig cfg;
  cfg.shortcut = false;  // keep the corner
  const auto l = limits(1.0, 1.0);  // corner radius v_max / omega_max = 1 m
  auto t = smoothPath(pathOf({{2, 2, 0}, {12, 2, 0}, {12, 12, 0}}), *world, l, cfg);
  // Rounded: the curve does not pass through the corner, and the curvature is finite and about 1/radius.
  double closest = 1e9;
  for (const auto& s : t.samples) closest = std::min(closest, (s.position - Vec3(12, 2, 0)).norm());
  EXPECT_GT(closest, 0.5);
  EXPECT_LT(closest, 3.0);
  EXPECT_GT(t.report.max_curvature, 0.3);
  EXPECT_LT(t.report.max_curvature, 1.5);
  // Turned left by 90 degrees, continuously.
  EXPECT_NEAR(t.samples.back().heading - t.samples.front().heading, std::numbers::pi / 2, 1e-6);
  EXPECT_GT(t.samples.front().speed + t.samples[t.samples.size() / 2].speed, 0.5);  // it does not crawl round the corner
  expectDrivable(t, *world, l, cfg);
  // The analytic form reproduces the samples' ends.
  EXPECT_NEAR((t.curve.point(t.curve.parameterMin()) - Vec3(2, 2, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((t.curve.point(t.curve.parameterMax()) - Vec3(12, 12, 0)).norm(), 0.0, 1e-12);
}

TEST(Smoother, HeadingWrapsAroundPi) {
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig cfg;
  cfg.shortcut = false;
  // Heading pi on the first edge, then turning left past -pi (i.e. to about -2.94 rad wrapped).
  cfg.initial_heading = -std::numbers::pi + 0.01;  // the same direction as +pi - 0.01
  auto t = smoothPath(pathOf({{15, 10, 0}, {8, 10, 0}, {3, 11, 0}}), *world, limits(), cfg);
  EXPECT_NEAR(t.initial_turn, -0.01, 1e-6);  // the short way, not a full turn
  EXPECT_LE(t.report.max_heading_jump, 1.0 * cfg.sample_dt + 1e-9);
  // The unwrapped heading goes from about -pi through -pi - 0.197 without any 2 pi jump.
  EXPECT_NEAR(t.samples.back().heading, -std::numbers::pi - std::atan2(1.0, 5.0), 1e-6);
  expectDrivable(t, *world, limits(), cfg);
  // Turning right at the wrap: the other way round.
  auto t2 = smoothPath(pathOf({{15, 10, 0}, {8, 10, 0}, {3, 9, 0}}), *world, limits(), SmootherConfig{});
  EXPECT_LE(t2.report.max_heading_jump, 1.0 * 0.05 + 1e-9);
  double max_step = 0;
  for (std::size_t i = 1; i < t2.samples.size(); ++i)
    max_step = std::max(max_step, std::abs(t2.samples[i].heading - t2.samples[i - 1].heading));
  EXPECT_LT(max_step, 0.06);
}

TEST(Smoother, CollisionFallbackTightensTheCorner) {
  // A box inside the corner: the polyline keeps 0.5 m from it, the default rounding would cut into it.
  auto sc = scenario2d(20, 0.2, "  - {type: box, min: [7, 1.5], max: [9.5, 4]}\n");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig cfg;
  cfg.shortcut = false;  // the diagonal would be free; this test is about the corner
  const auto path = pathOf({{1, 1, 0}, {10, 1, 0}, {10, 10, 0}});
  // One round only: the naive rounding collides and there is no round left to fix it.
  SmootherConfig naive = cfg;
  naive.max_fallback_iterations = 1;
  EXPECT_THROW(smoothPath(path, *world, limits(), naive), SmoothingError);

  auto t = smoothPath(path, *world, limits(), cfg);
  EXPECT_GT(t.report.fallback_iterations, 0);
  EXPECT_GE(t.report.min_clearance, 0.0);
  expectDrivable(t, *world, limits(), cfg);
}

TEST(Smoother, LimitsRespectedOnEverySampleOfAZigzag) {
  auto sc = scenario2d(40, 0.3, "  - {type: sphere, center: [20, 20], radius: 3}\n");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig cfg;
  cfg.shortcut = false;
  cfg.initial_heading = 2.5;
  const auto l = limits(2.0, 0.6);
  auto t = smoothPath(pathOf({{2, 2, 0}, {8, 10, 0}, {12, 3, 0}, {15, 12, 0}, {16, 12.5, 0}, {10, 30, 0}, {35, 35, 0},
                              {35, 5, 0}}),
                      *world, l, cfg);
  expectDrivable(t, *world, l, cfg);
  EXPECT_LE(t.report.max_speed, 0.85 * l.v_max + 1e-9);
  EXPECT_LE(t.report.max_yaw_rate, 0.85 * l.omega_max + 1e-9);
  EXPECT_LE(t.report.max_accel, cfg.max_accel * 1.05);
  EXPECT_GT(t.report.min_clearance, 0.0);
}

TEST(Smoother, ThreeDimensionalClimbRespectsVz) {
  const std::string text =
      "name: t3\ndimensions: 3\nbounds: {min: [0, 0, 0], max: [30, 30, 20]}\nrobot_radius: 0.3\nstart: [1, 1, 1]\n"
      "goal: [20, 20, 10]\ngoal_radius: 1\nvehicle: {model: unicycle, v_max: 2.0, omega_max: 0.6, vz_max: 0.5, dt: 1.0}\n"
      "obstacles:\n  - {type: sphere, center: [15, 5, 5], radius: 2}\n";
  auto sc = ddsnav::planner::parseScenario(text, "t3");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig cfg;
  const auto l = *sc.vehicle;
  auto t = smoothPath(pathOf({{2, 2, 1}, {10, 2, 8}, {10, 12, 8}, {20, 20, 3}}), *world, l, cfg);
  EXPECT_EQ(t.dimensions, 3);
  expectDrivable(t, *world, l, cfg);
  EXPECT_GT(t.report.max_vz, 0.1);
  EXPECT_NEAR(t.samples.back().position.z(), 3.0, 1e-9);
}

TEST(Smoother, ShortcuttingRemovesDetoursButNotThroughObstacles) {
  auto sc = scenario2d(20, 0.3, "  - {type: box, min: [9, 0], max: [11, 12]}\n");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  std::vector<Vec3> pts{{2, 2, 0}, {4, 8, 0}, {6, 13.5, 0}, {10, 13.5, 0}, {14, 13.5, 0}, {16, 6, 0}, {18, 2, 0}};
  auto out = shortcutPolyline(pts, *world, 0.1);
  EXPECT_LT(out.size(), pts.size());
  EXPECT_EQ(out.front(), pts.front());
  EXPECT_EQ(out.back(), pts.back());
  EXPECT_GE(out.size(), 3u);  // the wall stays in the way
  for (std::size_t i = 1; i < out.size(); ++i) EXPECT_TRUE(world->isSegmentFree(out[i - 1], out[i]));
}

TEST(Smoother, NoRoundingStopsAndTurnsInPlace) {
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  SmootherConfig cfg;
  cfg.shortcut = false;
  cfg.corner_radius = 0.0;
  auto t = smoothPath(pathOf({{2, 2, 0}, {12, 2, 0}, {12, 12, 0}}), *world, limits(), cfg);
  double closest = 1e9;
  for (const auto& s : t.samples) closest = std::min(closest, (s.position - Vec3(12, 2, 0)).norm());
  EXPECT_LT(closest, 1e-3);  // it goes through the corner
  EXPECT_LE(t.report.max_heading_jump, 0.85 * cfg.sample_dt + 1e-9);
  expectDrivable(t, *world, limits(), cfg);
  // The stop at the corner is what the report's slow time counts, and where.
  EXPECT_GT(t.report.slow_s, 0.5);
  EXPECT_LT((t.report.slowest_at - Vec3(12, 2, 0)).norm(), 0.5) << t.report.slowest_at.transpose();
}

TEST(Smoother, AStraightRunHasNoSlowTimeOnTheWay) {
  auto sc = scenario2d(20, 0.3, "");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto t = smoothPath(pathOf({{2, 2, 0}, {18, 2, 0}}), *world, limits());
  EXPECT_EQ(t.report.slow_s, 0.0) << "the start's acceleration and the end's braking are not slow stretches";
}

TEST(Smoother, BadInputGivesClearErrors) {
  auto sc = scenario2d(20, 0.3, "  - {type: box, min: [5, 0], max: [6, 10]}\n");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  auto expectError = [&](const std::vector<ddsnav::planner::State>& path, const std::string& needle,
                         ddsnav::planner::VehicleLimits l = limits()) {
    try {
      smoothPath(path, *world, l);
      ADD_FAILURE() << "expected an error containing '" << needle << "'";
    } catch (const SmoothingError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expectError({}, "empty");
  expectError(pathOf({{1, 1, 0}}), "single state");
  expectError(pathOf({{1, 1, 0}, {1, 1, 0}, {1, 1, 0}}), "same position");
  expectError(pathOf({{1, 1, 0}, {NAN, 2, 0}}), "non-finite");
  expectError(pathOf({{1, 1, 0}, {INFINITY, 2, 0}}), "non-finite");
  expectError(pathOf({{5.5, 5, 0}, {8, 15, 0}}), "start");          // inside the box
  expectError(pathOf({{2, 5, 0}, {8, 5, 0}}), "edge 0 -> 1");        // through the box
  expectError(pathOf({{2, 5, 0}, {2, 25, 0}}), "out of bounds");
  expectError(pathOf({{2, 5, 0}, {3, 5, 0}}), "v_max", limits(0.0));
  // Duplicates in the middle are removed, not an error.
  auto t = smoothPath(pathOf({{2, 5, 0}, {3, 12, 0}, {3, 12, 0}, {4, 15, 0}}), *world, limits());
  EXPECT_EQ(t.report.input_waypoints, 3u);
}

TEST(Smoother, PathHuggingAWallIsMovedAway) {
  // A corridor 1 m wide (y in [4.5, 5.5]); the planner's path runs 5 cm above the robot-inflated floor.
  auto sc = scenario2d(20, 0.2, "  - {type: box, min: [0, 0], max: [20, 4.5]}\n  - {type: box, min: [0, 5.5], max: [20, 20]}\n");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto path = pathOf({{1, 4.75, 0}, {6, 4.75, 0}, {12, 4.75, 0}, {19, 5.0, 0}});
  SmootherConfig keep;
  keep.clearance_target = 0.0;
  const auto hugging = smoothPath(path, *world, limits(), keep);
  EXPECT_LT(hugging.report.min_clearance, 0.06);
  SmootherConfig cfg;  // default target 0.2 m
  const auto moved = smoothPath(path, *world, limits(), cfg);
  // The start is where it is (5 cm); a little way in, the trajectory has the clearance it asked for.
  double min_inside = 1e9;
  for (const auto& s : moved.samples)
    if (s.position.x() > 2.0 && s.position.x() < 18.0) min_inside = std::min(min_inside, world->clearance(s.position));
  EXPECT_GT(min_inside, 0.15);
  expectDrivable(moved, *world, limits(), cfg);
}

TEST(Smoother, APathMovedOffARoughWallIsStraightenedNotKinked) {
  // A mapped wall is not flat: its face steps by a voxel here and there. Each piece of the path pushed off
  // it stops where its own clearance reaches the target, so the pieces end up staggered sideways; rounded
  // over 0.5 m edges, every stagger was a tight turn the vehicle had to crawl through.
  std::string floor;
  for (int k = 0; k < 20; ++k)
    floor += "  - {type: box, min: [" + std::to_string(k) + ", 0], max: [" + std::to_string(k + 1) + ", " +
             std::to_string(4.5 + 0.05 * (k % 2)) + "]}\n";
  auto sc = scenario2d(20, 0.2, floor);
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto path = pathOf({{1, 4.8, 0}, {7, 4.8, 0}, {13, 4.8, 0}, {19, 4.8, 0}});
  SmootherConfig cfg;
  cfg.clearance_target = 0.6;
  const auto t = smoothPath(path, *world, limits(), cfg);
  // Off its ends (which turn away from the wall they start next to), straight, and as far off the wall as asked.
  double max_curvature = 0.0, min_inside = 1e9;
  for (const auto& s : t.samples) {
    if (s.position.x() < 3.0 || s.position.x() > 17.0) continue;
    max_curvature = std::max(max_curvature, std::abs(s.curvature));
    min_inside = std::min(min_inside, world->clearance(s.position));
  }
  EXPECT_LT(max_curvature, 0.05);
  EXPECT_GT(min_inside, 0.9 * cfg.clearance_target);
  expectDrivable(t, *world, limits(), cfg);
}

// The farthest-in-sight search stops at a boundary of a predicate that is not monotone; every corner it leaves whose
// neighbours see each other is dropped afterwards. Random free walks among discs: no kept interior corner may have
// mutually visible neighbours (under the same test), and every kept edge stays free.
TEST(Smoother, ACornerTheSearchLeftIsDroppedWhenItsNeighboursSeeEachOther) {
  auto sc = scenario2d(40, 0.3,
                       "  - {type: sphere, center: [10, 10], radius: 2.5}\n  - {type: sphere, center: [22, 14], radius: 3}\n"
                       "  - {type: sphere, center: [30, 28], radius: 2}\n  - {type: sphere, center: [14, 28], radius: 3.5}\n"
                       "  - {type: box, min: [25, 2], max: [27, 10]}\n");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  std::mt19937 rng(20261207);
  std::uniform_real_distribution<double> step(-4.0, 4.0);
  for (int walk = 0; walk < 200; ++walk) {
    std::vector<Vec3> points{Vec3(2, 2, 0)};
    while (points.size() < 40) {
      const Vec3 next = points.back() + Vec3(step(rng), step(rng), 0);
      if (world->isFree(next) && world->isSegmentFree(points.back(), next)) points.push_back(next);
    }
    for (const double min_clearance : {0.0, 0.5}) {
      const auto out = shortcutPolyline(points, *world, min_clearance, 0.05);
      ASSERT_GE(out.size(), 2u);
      EXPECT_EQ(out.front(), points.front());
      EXPECT_EQ(out.back(), points.back());
      for (std::size_t k = 1; k < out.size(); ++k) EXPECT_TRUE(world->isSegmentFree(out[k - 1], out[k]));
      for (std::size_t k = 1; k + 1 < out.size(); ++k) {
        const double need = std::min({min_clearance, world->clearance(out[k - 1]), world->clearance(out[k + 1])}) - 0.05;
        const bool neighbours_see_each_other = world->isSegmentFree(out[k - 1], out[k + 1]) &&
                                               ddsnav::planner::segmentClearanceAtLeast(*world, out[k - 1], out[k + 1], need);
        EXPECT_FALSE(neighbours_see_each_other) << "walk " << walk << ", corner " << k << " of " << out.size();
      }
    }
  }
}

TEST(Smoother, ReportedMinimumClearanceIsTheLeastOfEverySample) {
  // The report measures only the samples that could be nearer than the least so far (the clearance is
  // 1-Lipschitz); the result must be what measuring every sample gives.
  auto sc = scenario2d(60, 0.3,
                       "  - {type: sphere, center: [15, 8], radius: 2}\n  - {type: sphere, center: [30, 13], radius: 1.5}\n"
                       "  - {type: box, min: [40, 0], max: [42, 8]}\n  - {type: sphere, center: [50, 16], radius: 3}\n");
  auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto path = pathOf({{2, 10, 0}, {22, 12, 0}, {36, 10, 0}, {45, 10, 0}, {58, 12, 0}});
  SmootherConfig cfg;
  cfg.clearance_target = 0.0;  // the path passes where the planner put it, close to the obstacles
  const auto t = smoothPath(path, *world, limits(), cfg);
  double least = std::numeric_limits<double>::infinity();
  for (const auto& sample : t.samples) least = std::min(least, world->clearance(sample.position));
  EXPECT_LT(least, 2.0);
  EXPECT_DOUBLE_EQ(t.report.min_clearance, least);
}

namespace {
// A world whose edge check only samples states every checkResolution() (the base class's check, as an
// OctoMap world does), around an exact scenario world.
class SampledEdgeWorld : public ddsnav::planner::CollisionWorld {
 public:
  explicit SampledEdgeWorld(std::unique_ptr<ddsnav::planner::CollisionWorld> inner) : inner_(std::move(inner)) {}
  int dimensions() const override { return inner_->dimensions(); }
  Vec3 boundsMin() const override { return inner_->boundsMin(); }
  Vec3 boundsMax() const override { return inner_->boundsMax(); }
  double robotRadius() const override { return inner_->robotRadius(); }
  bool isFree(const Vec3& p) const override { return inner_->isFree(p); }
  double clearance(const Vec3& p) const override { return inner_->clearance(p); }
  std::vector<ddsnav::planner::NearbyObstacle> obstaclesNear(const Vec3& p, double range) const override {
    return inner_->obstaclesNear(p, range);
  }

 private:
  std::unique_ptr<ddsnav::planner::CollisionWorld> inner_;
};
}  // namespace

TEST(Smoother, GrazingPlannerEdgeGetsADetour) {
  // The world checks edges only every 2 m, so the planner's edge passes "free" right past a small post
  // that the robot disc actually touches. The smoother samples finer, finds it and detours.
  SampledEdgeWorld world(ddsnav::planner::makeScenarioWorld(scenario2d(10, 0.2, "  - {type: sphere, center: [4, 5.25], radius: 0.1}\n")));
  world.setCheckResolution(2.0);
  ASSERT_TRUE(world.isSegmentFree({1, 5, 0}, {9, 5, 0}));
  ASSERT_FALSE(world.isFree({4, 5, 0}));
  SmootherConfig cfg;
  cfg.clearance_target = 0.0;  // keep the planner's geometry: this test is about the fallback
  auto t = smoothPath(pathOf({{1, 5, 0}, {9, 5, 0}}), world, limits(), cfg);
  EXPECT_GT(t.report.fallback_iterations, 0);
  EXPECT_GT(t.report.shortcut_waypoints, 2u);  // a detour corner was added
  for (const auto& s : t.samples) EXPECT_TRUE(world.isFree(s.position));
  EXPECT_GE(t.report.min_clearance, 0.0);
}

namespace {
// The sampled edge check, and a nearest obstacle that is straight below the query point (the ground a map widened a
// column from, not the column's corner the query point grazes).
class GroundBelowWorld : public SampledEdgeWorld {
 public:
  using SampledEdgeWorld::SampledEdgeWorld;
  std::vector<ddsnav::planner::NearbyObstacle> obstaclesNear(const Vec3& p, double) const override {
    return {{0, Vec3(p.x(), p.y(), 0.0), p.z()}};
  }
};
}  // namespace

TEST(Smoother, AnEdgeGrazingABoxCornerIsPushedOffSidewaysWithoutSharpCorners) {
  // A tall box; the path's first edge passes its vertical edge at (10, 6) 0.29 m off (robot radius 0.3): a 15 cm
  // chord the 2 m edge check steps over. Pushing away from the "nearest obstacle" (the ground below) goes up, along
  // the box: the edge must be pushed off sideways, and the corner after it keep its rounding.
  const std::string text =
      "name: corner\ndimensions: 3\nbounds: {min: [0, 0, 0], max: [30, 30, 20]}\nrobot_radius: 0.3\nstart: [1, 1, 5]\n"
      "goal: [20, 20, 5]\ngoal_radius: 1\nvehicle: {model: unicycle, v_max: 1.0, omega_max: 1.0, vz_max: 0.5, dt: 1.0}\n"
      "obstacles:\n  - {type: box, min: [10, 6, 0], max: [12, 8, 20]}\n";
  const auto sc = ddsnav::planner::parseScenario(text, "corner");
  GroundBelowWorld world(ddsnav::planner::makeScenarioWorld(sc));
  world.setCheckResolution(2.0);
  const Vec3 along = Vec3(1, -1, 0).normalized();
  const Vec3 graze = Vec3(10, 6, 5) + 0.29 * Vec3(-1, -1, 0).normalized();
  const Vec3 a = graze - 6.1 * along, b = graze + 5.9 * along, c = b + Vec3(6, 0, 0);
  ASSERT_TRUE(world.isSegmentFree(a, b));
  ASSERT_FALSE(world.isFree(graze));
  SmootherConfig cfg;
  cfg.clearance_target = 0.0;  // keep the planner's geometry: this test is about the fallback
  cfg.shortcut = false;
  const auto t = smoothPath(pathOf({a, b, c}), world, *sc.vehicle, cfg);
  for (const auto& s : t.samples) ASSERT_TRUE(world.isFree(s.position)) << s.position.transpose();
  EXPECT_GT(t.report.shortcut_waypoints, 3u);  // a detour corner was added
  EXPECT_LT(t.report.max_curvature, 2.0);      // no corner tightened to a point
}

// expectDrivable for a trajectory that starts moving: every sample free and within the limits, the first one
// at `speed` along `heading`, without a turn in place.
static void expectMovingStart(const Trajectory& t, const ddsnav::planner::CollisionWorld& world,
                       const ddsnav::planner::VehicleLimits& l, double speed, double heading) {
  for (const auto& s : t.samples) {
    EXPECT_TRUE(world.isFree(s.position)) << "t=" << s.time;
    EXPECT_LE(s.speed, l.v_max + 1e-9) << "t=" << s.time;
    EXPECT_LE(std::abs(s.yaw_rate), l.omega_max + 1e-9) << "t=" << s.time;
  }
  EXPECT_EQ(t.report.samples_in_collision, 0u);
  EXPECT_NEAR(t.samples.front().speed, speed, 1e-6);
  EXPECT_NEAR(t.initial_turn, 0.0, 1e-6);
  EXPECT_NEAR(t.samples.front().heading, heading, 1e-6);
}

// A replan ahead starts moving: with initial_speed the trajectory begins at that speed, tangent to the
// vehicle's heading through a lead-in (no turn in place), where the start at rest would stop the vehicle.
TEST(Smoother, AMovingStartKeepsItsSpeedAndHeading) {
  const auto sc = scenario2d(60, 0.3, "");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = limits(2.0, 0.5);
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;
  const auto path = pathOf({{5, 5, 0}, {20, 15, 0}, {40, 15, 0}});  // first edge 34 degrees off the heading
  const Trajectory at_rest = smoothPath(path, *world, l, cfg);
  EXPECT_DOUBLE_EQ(at_rest.samples.front().speed, 0.0);
  EXPECT_GT(std::abs(at_rest.initial_turn), 0.2);

  cfg.initial_speed = 1.5;
  const Trajectory moving = smoothPath(path, *world, l, cfg);
  expectMovingStart(moving, *world, l, 1.5, 0.0);
  for (const auto& s : moving.samples) {
    if (s.time > 0 && s.time < moving.duration() - 3.0) {
      EXPECT_GT(s.speed, 0.5) << "stopped at t=" << s.time;
    }
  }
  EXPECT_LT(moving.duration(), at_rest.duration());
}

// In a corridor 0.7 m wider than the robot, a replan ahead starts 0.1 m from a wall, heading 4 degrees toward it, where
// the trajectory being flown curves away: every straight lead-in comes closer than the start is, and the plan could
// only start at rest. Along the flown trajectory (lead_in_path) it starts at speed.
TEST(Smoother, AMovingStartInACorridorLeadsInAlongTheFlownTrajectory) {
  const auto sc = scenario2d(60, 0.5, "  - {type: box, min: [0, 8], max: [60, 9.4]}\n  - {type: box, min: [0, 11.1], max: [60, 12.5]}\n");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = limits(2.0, 0.5);
  const double heading = std::atan(-0.07);
  SmootherConfig cfg;
  cfg.initial_heading = heading;
  cfg.initial_speed = 1.5;
  const auto path = pathOf({{5, 10, 0}, {55, 10.2, 0}});
  const Trajectory straight_only = smoothPath(path, *world, l, cfg);
  EXPECT_DOUBLE_EQ(straight_only.samples.front().speed, 0.0);
  EXPECT_NE(straight_only.report.lead_in_failure.find("too close to an obstacle"), std::string::npos) << straight_only.report.lead_in_failure;
  // Down to 0.06 m from the wall and back, then level 0.16 m from it.
  for (double d = 0.0; d <= 20.0; d += 0.5) {
    const double y = d <= 3.5 ? 10.0 - 0.07 * d + 0.02 * d * d
                   : d <= 5.25 ? 10.0 + 0.07 * (d - 3.5) - 0.02 * (d - 3.5) * (d - 3.5)
                               : 10.06125;
    cfg.lead_in_path.emplace_back(5.0 + d, y, 0.0);
  }
  const Trajectory along = smoothPath(path, *world, l, cfg);
  expectMovingStart(along, *world, l, 1.5, heading);
  EXPECT_TRUE(along.report.lead_in_failure.empty()) << along.report.lead_in_failure;
  EXPECT_GE(along.report.lead_in_along_flown, 0.5);
  EXPECT_DOUBLE_EQ(straight_only.report.lead_in_along_flown, 0.0);
  // A lead-in path that does not start at the path's start is not used.
  for (auto& p : cfg.lead_in_path) p.y() += 0.2;
  EXPECT_DOUBLE_EQ(smoothPath(path, *world, l, cfg).samples.front().speed, 0.0);
}

// An edge a whole wall now cuts (planned on a map that had not seen it) is neither moved off nor bridged near its
// middle within the repair distance: the lattice route round the wall's end mends it; with no way round it is refused.
TEST(Smoother, AnEdgeAWallCutsIsMendedByTheWayRoundIt) {
  const auto path = pathOf({{5, 10, 0}, {25, 10, 0}});
  const auto l = limits(1.0, 1.0);
  SmootherConfig cfg;
  cfg.repair_distance = 0.5;
  const auto open = ddsnav::planner::makeScenarioWorld(scenario2d(40, 0.5, "  - {type: box, min: [14, 2], max: [16, 16]}\n"));
  const Trajectory t = smoothPath(path, *open, l, cfg);
  EXPECT_GE(t.report.repaired_waypoints, 1u);
  for (const auto& s : t.samples) EXPECT_TRUE(open->isFree(s.position)) << s.position.transpose();
  EXPECT_GT(t.report.length, 20.0 + 2.0);  // round the wall's end at y = 16
  cfg.repair_distance = 0.0;
  EXPECT_THROW(smoothPath(path, *open, l, cfg), SmoothingError);
  cfg.repair_distance = 0.5;
  const auto closed = ddsnav::planner::makeScenarioWorld(scenario2d(40, 0.5, "  - {type: box, min: [14, 0], max: [16, 40]}\n"));
  EXPECT_THROW(smoothPath(path, *closed, l, cfg), SmoothingError);
}

// A slow moving start with an obstacle 4.5 m ahead: no lead-in fits the full-speed turn radius (8 m), but the
// vehicle turns tighter at its own speed, so the trajectory still starts moving instead of at rest.
TEST(Smoother, ASlowMovingStartTurnsAtItsOwnSpeedsRadius) {
  const auto sc = scenario2d(60, 0.3, "  - {type: box, min: [9.5, 0], max: [11, 9]}\n");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = limits(5.0, 0.2 * std::numbers::pi);
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;  // toward the obstacle
  cfg.initial_speed = 0.6;
  const Trajectory t = smoothPath(pathOf({{5, 5, 0}, {8, 12, 0}, {20, 12, 0}}), *world, l, cfg);
  expectMovingStart(t, *world, l, 0.6, 0.0);
}

// A UAV climbing toward a step in the terrain: no level lead-in clears the step nor fits the steep first edge,
// the one along its climb does, so the trajectory starts moving, climbing as the vehicle was.
// A 3-D world with a 5 m step from x = step_x on, for a UAV (5 m/s, 0.6 rad/s, 2 m/s climb) moving at 3 m/s along x.
static ddsnav::planner::Scenario stepScenario(double step_x) {
  const std::string text =
      "name: step\ndimensions: 3\nbounds: {min: [0, 0, 0], max: [30, 30, 20]}\nrobot_radius: 0.3\nstart: [2, 15, 6]\n"
      "goal: [25, 15, 8]\ngoal_radius: 1\nvehicle: {model: unicycle, v_max: 5.0, omega_max: 0.6, vz_max: 2.0, dt: 1.0}\n"
      "obstacles:\n  - {type: box, min: [" + std::to_string(step_x) + ", 0, 0], max: [30, 30, 5]}\n";
  return ddsnav::planner::parseScenario(text, "step");
}

TEST(Smoother, AClimbingStartLeadsInAlongItsClimb) {
  const auto sc = stepScenario(4.0);
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = *sc.vehicle;
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;
  cfg.initial_speed = 3.0;
  const auto path = pathOf({{2, 15, 5.0}, {7, 17.5, 8.5}, {25, 17.5, 8.5}});  // the first edge 27 deg to the left
  const Trajectory level = smoothPath(path, *world, l, cfg);  // as before: no climb given
  EXPECT_DOUBLE_EQ(level.samples.front().speed, 0.0);
  cfg.initial_vz = 1.2;  // climbing at 0.4 (22 deg)
  const Trajectory climbing = smoothPath(path, *world, l, cfg);
  expectMovingStart(climbing, *world, l, 3.0, 0.0);
  EXPECT_NEAR(climbing.samples.front().vz / climbing.samples.front().speed, 0.4, 0.05);
}

// The lead-in's corner is a horizontal turn: a level start before a path that climbs steeply over a step, a little
// to the left, fits a 2.7 m lead-in (a 24 degree turn), where the 3-D angle (57 degrees) did not.
TEST(Smoother, ALeadInsCornerIsMeasuredInTheHorizontal) {
  const auto sc = stepScenario(6.0);
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = *sc.vehicle;
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;
  cfg.initial_speed = 3.0;
  const Trajectory t = smoothPath(pathOf({{2, 15, 4.6}, {7, 16, 8}, {25, 16, 8}}), *world, l, cfg);
  EXPECT_TRUE(t.report.lead_in_failure.empty()) << t.report.lead_in_failure;
  for (const auto& sample : t.samples) EXPECT_TRUE(world->isFree(sample.position)) << "t=" << sample.time;
  // Moving, no turn in place; slower than 3 m/s where the lead-in bends up into the climb (vz_max).
  EXPECT_GT(t.samples.front().speed, 2.0);
  EXPECT_NEAR(t.initial_turn, 0.0, 1e-9);
  EXPECT_NEAR(t.samples.front().heading, 0.0, 1e-6);
}

// A moving start 6 m before a 60 degree corner: a lead-in along the heading fits, but from 4 m/s the vehicle cannot
// slow to the corner's speed in that room, so the trajectory starts slower than the vehicle (3.6 m/s), at what the
// corner allows (SmootherConfig::initial_speed; the tracker judges whether the vehicle can take that over; a
// sharper corner this near fits no lead-in at all). With room to slow down it keeps the vehicle's speed.
TEST(Smoother, AMovingStartBeforeATightCornerStartsAtWhatTheCornerAllows) {
  const auto world = ddsnav::planner::makeScenarioWorld(scenario2d(60, 0.3, ""));
  const auto l = limits(5.0, 0.6);
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;
  cfg.initial_speed = 4.0;
  const Trajectory near = smoothPath(pathOf({{5, 30, 0}, {11, 30, 0}, {14, 35.2, 0}}), *world, l, cfg);
  EXPECT_TRUE(near.report.lead_in_failure.empty()) << near.report.lead_in_failure;
  EXPECT_GT(near.samples.front().speed, 0.1);
  EXPECT_LT(near.samples.front().speed, 4.0 - 0.3);
  const Trajectory far = smoothPath(pathOf({{5, 30, 0}, {35, 30, 0}, {38, 35.2, 0}}), *world, l, cfg);
  EXPECT_NEAR(far.samples.front().speed, 4.0, 1e-6);
}

// No room for a lead-in (a wall right ahead of the heading): the trajectory starts at rest and turns.
TEST(Smoother, AMovingStartWithoutRoomStartsAtRest) {
  const auto sc = scenario2d(60, 0.3, "  - {type: box, min: [5.6, 0], max: [7, 60]}\n");  // 0.3 m of room ahead
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = limits(2.0, 0.5);
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;  // facing the wall
  cfg.initial_speed = 1.5;
  const Trajectory t = smoothPath(pathOf({{5, 5, 0}, {5, 30, 0}}), *world, l, cfg);
  expectDrivable(t, *world, l, cfg);
  EXPECT_DOUBLE_EQ(t.samples.front().speed, 0.0);
  EXPECT_NEAR(std::abs(t.initial_turn), std::numbers::pi / 2, 1e-6);
}

// A plan asked ahead of a moving vehicle that turns back (inside a bug trap every replan does): no lead-in fits at
// speed, so the trajectory brakes to rest along the heading at lead_in_decel, turns in place and joins the path,
// instead of starting at rest where the vehicle arrives at 3 m/s. Without the braking lead-in it starts at rest.
TEST(Smoother, AMovingStartWhosePathTurnsBackBrakesAlongItsHeading) {
  const auto sc = scenario2d(60, 0.3, "");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = limits(5.0, 0.6);
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;  // east
  cfg.initial_speed = 3.0;
  cfg.lead_in_decel = 1.7;
  const auto path = pathOf({{20, 20, 0}, {14, 24, 0}, {5, 40, 0}});  // back west-north-west
  const Trajectory t = smoothPath(path, *world, l, cfg);
  expectMovingStart(t, *world, l, 3.0, 0.0);
  const double stop = 1.25 * 9.0 / (2 * 1.7) + 0.3;  // the stop at 1.7 m/s^2 with its slack
  EXPECT_NEAR(t.report.lead_in_braking, stop, 1e-9);
  EXPECT_FALSE(t.report.lead_in_failure.empty());  // why none fitted at speed
  // Brakes no harder than asked, along the heading, and comes to rest near the stop point before turning.
  bool came_to_rest = false;
  for (std::size_t i = 1; i < t.samples.size(); ++i) {
    const auto& a = t.samples[i - 1];
    const auto& b = t.samples[i];
    EXPECT_LE((a.speed - b.speed) / (b.time - a.time), 1.7 + 1e-6) << "t=" << b.time;
    if (b.arc_length < stop - 1.0) {
      EXPECT_NEAR(b.position.y(), 20.0, 1e-6) << "t=" << b.time;
      EXPECT_NEAR(b.heading, 0.0, 1e-6) << "t=" << b.time;
    }
    if (b.speed < 0.05 && b.position.x() > 20.0 + stop - 2.0) came_to_rest = true;
  }
  EXPECT_TRUE(came_to_rest);
  EXPECT_NEAR(t.samples.back().position.x(), 5.0, 1e-6);

  cfg.lead_in_decel = 0.0;
  const Trajectory at_rest = smoothPath(path, *world, l, cfg);
  EXPECT_DOUBLE_EQ(at_rest.samples.front().speed, 0.0);
  EXPECT_DOUBLE_EQ(at_rest.report.lead_in_braking, 0.0);
}

// Without lead_in_decel a stop no longer than short_braking_m still brakes (at max_accel) where no lead-in fits at
// speed; a longer one is refused as before (the trajectory starts at rest).
TEST(Smoother, AShortStopBrakesWithoutLeadInDecel) {
  const auto sc = scenario2d(60, 0.3, "");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = limits(5.0, 0.6);
  const auto path = pathOf({{20, 20, 0}, {14, 24, 0}, {5, 40, 0}});  // turns back
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;
  cfg.initial_speed = 1.2;  // a stop of 0.72 m at 1 m/s^2
  cfg.short_braking_m = 1.0;
  const Trajectory braking = smoothPath(path, *world, l, cfg);
  expectMovingStart(braking, *world, l, 1.2, 0.0);
  EXPECT_NEAR(braking.report.lead_in_braking, 1.25 * 1.44 / 2.0 + 0.3, 1e-9);
  for (std::size_t i = 1; i < braking.samples.size(); ++i) {
    const auto& a = braking.samples[i - 1];
    const auto& b = braking.samples[i];
    EXPECT_LE((a.speed - b.speed) / (b.time - a.time), cfg.max_accel + 1e-6) << "t=" << b.time;
  }
  cfg.initial_speed = 2.0;  // a stop of 2 m: longer than short_braking_m
  const Trajectory refused = smoothPath(path, *world, l, cfg);
  EXPECT_DOUBLE_EQ(refused.samples.front().speed, 0.0);
  EXPECT_DOUBLE_EQ(refused.report.lead_in_braking, 0.0);
  cfg.short_braking_m = -1.0;
  EXPECT_THROW(smoothPath(path, *world, l, cfg), SmoothingError);
}

// A plan that turns back where the vehicle arrives at speed in a corridor: the trajectory being flown, braked to rest
// along itself, then the path from rest — one trajectory that keeps the vehicle on the flown curve while it brakes,
// turns in place at the stop and ends at the path's end. A braking stretch the world blocks is refused.
TEST(Smoother, APlanThatTurnsBackIsFlownAfterBrakingAlongTheFlownTrajectory) {
  const auto sc = scenario2d(60, 0.5, "  - {type: box, min: [0, 8], max: [60, 9.4]}\n  - {type: box, min: [0, 11.1], max: [60, 12.5]}\n");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = limits(5.0, 0.6);
  // Being flown: east along the corridor, a slight S, at up to 0.85 x 5 m/s.
  const Trajectory flown = smoothPath(pathOf({{2, 10.2, 0}, {20, 10.4, 0}, {40, 10.1, 0}, {58, 10.3, 0}}), *world, l);
  const double switch_at = 0.5 * flown.duration();
  const auto from = flown.at(switch_at);
  ASSERT_GT(from.speed, 2.0);
  const double decel = 1.7;
  const Trajectory braking = brakeAlong(flown, switch_at, from.speed, decel);
  const auto back = pathOf({{from.position.x(), from.position.y(), 0}, {5, 10.3, 0}});  // the plan: back west

  SmootherConfig cfg;
  cfg.initial_heading = from.heading;
  cfg.initial_speed = from.speed;
  const Trajectory at_speed = smoothPath(back, *world, l, cfg);
  EXPECT_LT(at_speed.samples.front().speed, 0.1);  // no lead-in at speed: it would be refused

  const Trajectory t = smoothAfterBraking(back, braking, *world, l, cfg);
  EXPECT_NEAR(t.samples.front().speed, from.speed, 1e-9);
  EXPECT_NEAR(t.report.lead_in_braking, braking.length(), 1e-9);
  EXPECT_NEAR(t.report.length, t.length(), 1e-9);
  const auto stop = braking.samples.back();
  bool turned_at_rest = false;
  for (std::size_t i = 1; i < t.samples.size(); ++i) {
    const auto& a = t.samples[i - 1];
    const auto& b = t.samples[i];
    ASSERT_GT(b.time, a.time) << i;
    EXPECT_TRUE(world->isFree(b.position)) << "t=" << b.time;
    EXPECT_LE(std::abs(b.heading - a.heading), l.omega_max * (b.time - a.time) + 1e-6) << "t=" << b.time;
    if (b.time <= stop.time) {
      EXPECT_LE((a.speed - b.speed) / (b.time - a.time), decel + 1e-6) << "t=" << b.time;
      EXPECT_LT((b.position - flown.at(timeAtArcLength(flown, flown.at(switch_at).arc_length + b.arc_length)).position).norm(), 0.01)
          << "off the flown curve at t=" << b.time;
    }
    if (b.speed < 0.05 && (b.position - stop.position).norm() < 0.05 && std::abs(b.heading - stop.heading) > 1.0) turned_at_rest = true;
    EXPECT_LT(b.position.x(), stop.position.x() + 0.05) << "past the stop at t=" << b.time;
  }
  EXPECT_TRUE(turned_at_rest);
  EXPECT_NEAR(t.samples.back().position.x(), 5.0, 1e-6);
  EXPECT_NEAR(t.samples.back().position.y(), 10.3, 1e-6);

  // The stretch runs into a wall the world now has: refused.
  const auto walled = ddsnav::planner::makeScenarioWorld(scenario2d(
      60, 0.5, "  - {type: box, min: [0, 8], max: [60, 9.4]}\n  - {type: box, min: [0, 11.1], max: [60, 12.5]}\n"
               "  - {type: box, min: [" + std::to_string(stop.position.x() - 1.0) + ", 9.4], max: [60, 11.1]}\n"));
  EXPECT_THROW(smoothAfterBraking(back, braking, *walled, l, cfg), SmoothingError);
  EXPECT_THROW(smoothAfterBraking(back, Trajectory{}, *world, l, cfg), SmoothingError);
}

// No room to brake along the heading (a wall 2 m ahead of a vehicle at 3 m/s): no braking lead-in either, the
// trajectory starts at rest and says why.
TEST(Smoother, ABrakingLeadInNeedsRoomToStop) {
  const auto sc = scenario2d(60, 0.3, "  - {type: box, min: [22.3, 0], max: [24, 60]}\n");
  const auto world = ddsnav::planner::makeScenarioWorld(sc);
  const auto l = limits(5.0, 0.6);
  SmootherConfig cfg;
  cfg.initial_heading = 0.0;
  cfg.initial_speed = 3.0;
  cfg.lead_in_decel = 1.7;
  const Trajectory t = smoothPath(pathOf({{20, 20, 0}, {14, 24, 0}, {5, 40, 0}}), *world, l, cfg);
  EXPECT_DOUBLE_EQ(t.samples.front().speed, 0.0);
  EXPECT_DOUBLE_EQ(t.report.lead_in_braking, 0.0);
  EXPECT_NE(t.report.lead_in_failure.find("the braking line is blocked"), std::string::npos) << t.report.lead_in_failure;
}

// A trajectory that crawls (below 1 cm/s, not turning in place) for more than 5 s is found, with where; starting at
// rest, turning in place and stopping at the end are not crawling.
TEST(Smoother, ACrawlIsFoundAndNamed) {
  const auto l = limits(5.0, 0.6);
  Trajectory t;
  for (int k = 0; k <= 400; ++k) {
    TrajectorySample s;
    s.time = 0.05 * k;
    s.position = Vec3(0.001 * k, 0, 0);
    s.speed = k == 0 ? 0.0 : 0.02;  // 2 cm/s: slow, not a crawl
    t.samples.push_back(s);
  }
  EXPECT_FALSE(findCrawl(t, l));
  for (auto& s : t.samples) s.speed = 0.0, s.yaw_rate = 0.5;  // turning in place for 20 s
  EXPECT_FALSE(findCrawl(t, l));
  for (std::size_t k = 100; k < t.samples.size(); ++k) t.samples[k].speed = 0.001, t.samples[k].yaw_rate = -0.003;  // 15 s of crawl
  const auto crawl = findCrawl(t, l);
  ASSERT_TRUE(crawl);
  EXPECT_NE(crawl->find("from t = 5.0 s at (0.10, 0.00, 0.00)"), std::string::npos) << *crawl;
}

// r = 0.3; a box x in [5, 6], y in [0, 10]: the robot is free from x = 4.7 on the left.
std::unique_ptr<ddsnav::planner::CollisionWorld> wallAtFive() {
  return ddsnav::planner::makeScenarioWorld(scenario2d(20, 0.3, "  - {type: box, min: [5, 0], max: [6, 10]}\n"));
}

// repair_distance: a state a few centimetres inside a wall's inflated face is moved off it, an edge that grazes a corner
// gets a point around it; a state deep inside is still refused; 0 refuses as before; a bad distance is an error.
TEST(Smoother, StatesAndEdgesJustInCollisionAreRepairedWithinTheDistance) {
  const auto world = wallAtFive();
  const auto into_face = pathOf({{2, 5, 0}, {4.8, 5, 0}, {2, 9, 0}});  // the middle state 0.1 m into the face
  SmootherConfig refuse;
  EXPECT_THROW(smoothPath(into_face, *world, limits(), refuse), SmoothingError);
  SmootherConfig repair;
  repair.repair_distance = 0.3;
  const Trajectory moved = smoothPath(into_face, *world, limits(), repair);
  EXPECT_EQ(moved.report.repaired_waypoints, 1u);
  expectDrivable(moved, *world, limits(), repair);

  // An edge past the box's top end (y = 10) 0.2 m from it, 0.1 m too close, between two free states.
  const auto grazing = pathOf({{4.0, 10.2, 0}, {7.0, 10.2, 0}, {8, 15, 0}});
  EXPECT_FALSE(world->isSegmentFree(Vec3(4.0, 10.2, 0), Vec3(7.0, 10.2, 0)));
  EXPECT_THROW(smoothPath(grazing, *world, limits(), refuse), SmoothingError);
  const Trajectory bridged = smoothPath(grazing, *world, limits(), repair);
  EXPECT_GE(bridged.report.repaired_waypoints, 1u);
  expectDrivable(bridged, *world, limits(), repair);

  // Half a metre deep, beyond the distance: the state is left out and the path goes on between its neighbours.
  const Trajectory left_out = smoothPath(pathOf({{2, 5, 0}, {5.5, 5, 0}, {2, 9, 0}}), *world, limits(), repair);
  EXPECT_EQ(left_out.report.repaired_waypoints, 1u);
  expectDrivable(left_out, *world, limits(), repair);
  for (const auto& s : left_out.samples) EXPECT_LT(s.position.x(), 4.7) << s.position.transpose();
  // The last state is where the path must end: refused, and the error names it.
  try {
    smoothPath(pathOf({{2, 5, 0}, {2, 9, 0}, {5.5, 5, 0}}), *world, limits(), repair);
    ADD_FAILURE() << "a path ending 0.8 m inside the inflated box was repaired";
  } catch (const SmoothingError& e) {
    EXPECT_NE(std::string(e.what()).find("path state 2"), std::string::npos) << e.what();
  }
  SmootherConfig bad;
  bad.repair_distance = -1.0;
  EXPECT_THROW(smoothPath(into_face, *world, limits(), bad), SmoothingError);
}

// The start too: a vehicle at rest 8 cm inside a wall's inflated face (the planner moved it off its own world's face,
// the tracker's world is a little wider there) starts its trajectory at the nearest free position; a start deeper than
// the distance is refused, naming the start.
TEST(Smoother, AStartJustInCollisionIsMovedWithinTheDistance) {
  const auto world = wallAtFive();
  const auto from_face = pathOf({{4.78, 5, 0}, {2, 5, 0}, {2, 9, 0}});
  ASSERT_FALSE(world->isFree(Vec3(4.78, 5, 0)));
  EXPECT_THROW(smoothPath(from_face, *world, limits(), SmootherConfig{}), SmoothingError);  // repair_distance 0: refused
  SmootherConfig repair;
  repair.repair_distance = 0.3;
  const Trajectory moved = smoothPath(from_face, *world, limits(), repair);
  EXPECT_GE(moved.report.repaired_waypoints, 1u);
  ASSERT_FALSE(moved.samples.empty());
  EXPECT_LT((moved.samples.front().position - Vec3(4.78, 5, 0)).norm(), 0.3) << moved.samples.front().position.transpose();
  expectDrivable(moved, *world, limits(), repair);
  try {
    smoothPath(pathOf({{5.5, 5, 0}, {2, 5, 0}, {2, 9, 0}}), *world, limits(), repair);
    ADD_FAILURE() << "a start 0.8 m inside the inflated box was moved";
  } catch (const SmoothingError& e) {
    EXPECT_NE(std::string(e.what()).find("path start"), std::string::npos) << e.what();
  }
}
