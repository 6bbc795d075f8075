// The detector + tracker over a whole drive through a shipped scenario, as the demo pipeline runs
// them: at every scan the tracked set must stay tight around the real obstacles and keep the
// start, the goal and the vehicle free for the planner.

#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/obstacle_tracker.hpp"
#include "ddsnav/sim/range_sensor.hpp"

#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/planner/planner.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <numbers>
#include <string>

namespace ddsnav::perception {
namespace {

const std::string kScenarios = DDSNAV_SOURCE_DIR "/configs/scenarios/";

// Poses every `step` metres along a polyline, heading along it.
std::vector<sim::SensorPose> posesAlong(const std::vector<Eigen::Vector3d>& waypoints, double step) {
  std::vector<sim::SensorPose> poses;
  for (std::size_t k = 0; k + 1 < waypoints.size(); ++k) {
    const Eigen::Vector3d d = waypoints[k + 1] - waypoints[k];
    const int n = static_cast<int>(std::ceil(d.norm() / step));
    for (int i = 0; i < n; ++i) poses.push_back({waypoints[k] + d * (double(i) / n), std::atan2(d.y(), d.x())});
  }
  poses.push_back({waypoints.back(), poses.back().yaw});
  return poses;
}

planner::Scenario withoutRobot(planner::Scenario s) {
  s.robot_radius = 0.0;
  return s;
}

// Perimeter of an obstacle's footprint, for the bound on the track count.
double perimeter(const planner::Obstacle& o) {
  switch (o.type) {
    case planner::ObstacleType::Box: return 2.0 * (o.size.x() + o.size.y());
    case planner::ObstacleType::Sphere: return 2.0 * std::numbers::pi * o.radius;
    case planner::ObstacleType::Ellipsoid: {  // Ramanujan
      const double a = o.semi_axes.x(), b = o.semi_axes.y();
      return std::numbers::pi * (3 * (a + b) - std::sqrt((3 * a + b) * (a + 3 * b)));
    }
    default: return 0.0;
  }
}

std::vector<planner::EllipsoidObstacle> asPlannerObstacles(const std::vector<ObstacleEllipsoid>& tracked) {
  std::vector<planner::EllipsoidObstacle> out;
  for (const auto& t : tracked)
    out.push_back({static_cast<int>(t.id), t.center, t.semi_axes.cwiseMax(1e-3), t.axes});
  return out;
}

TEST(Drive, Demo2dEllipsesStayOnTheObstaclesAtEveryScan) {
  const auto scenario = planner::loadScenario(kScenarios + "demo_2d.yaml");
  const auto truth = planner::makeScenarioWorld(withoutRobot(scenario));  // clearance = distance to surfaces
  std::vector<std::unique_ptr<planner::CollisionWorld>> single;          // one world per obstacle: ownership
  for (const auto& o : scenario.obstacles) {
    auto s = withoutRobot(scenario);
    s.obstacles = {o};
    single.push_back(planner::makeScenarioWorld(s));
  }
  auto config = sim::RangeSensorConfig::scanner2d(720, 30.0);
  config.walls = false;  // as the demo's sim
  config.range_noise_sigma = 0.02;
  config.invalid_fraction = 0.01;
  sim::RangeSensor sensor(scenario, config);
  DetectorParams params;
  params.beam_spacing = 2 * std::numbers::pi / 720;
  ObstacleDetector detector(params);
  ObstacleTracker tracker(TrackerParams::matching(params));

  double pieces = 0;
  for (const auto& o : scenario.obstacles) pieces += std::ceil(perimeter(o) / params.max_segment_length);
  const auto poses = posesAlong({{3, 3, 0}, {8, 6, 0}, {8, 30, 0}, {36, 35, 0}}, 0.17);
  ASSERT_GT(poses.size(), 300u);

  std::map<std::uint64_t, std::size_t> owner;  // track id -> obstacle it was first nearest to
  std::size_t step = 0, peak = 0;
  int plans = 0;
  double worst_free = 0.0;  // largest distance from an obstacle of a point inside an ellipse
  if (const char* length = std::getenv("DRIVE_SEGMENT")) {
    params.max_segment_length = std::atof(length);
    if (const char* width = std::getenv("DRIVE_WIDTH")) params.max_segment_width = std::atof(width);
    detector = ObstacleDetector(params);
    tracker = ObstacleTracker(TrackerParams::matching(params));
  }
  for (const auto& pose : poses) {
    const auto cloud = sensor.scan(pose, 0.1 * static_cast<double>(step));
    const auto& tracked = tracker.update(detector.detect(cloud.points, cloud.origin), cloud.origin);
    peak = std::max(peak, tracked.size());
    const std::string where = " at scan " + std::to_string(step) + ", vehicle (" + std::to_string(pose.position.x()) +
                              ", " + std::to_string(pose.position.y()) + ")";
    for (const auto& t : tracked) {
      // (i) the centre is on (or inside) a real obstacle, not in free space.
      ASSERT_LE(truth->clearance(t.center), 0.5) << "track " << t.id << " centre " << t.center.transpose() << where;
      // ...and its id stays on the obstacle it started on.
      std::size_t nearest = 0;
      for (std::size_t k = 1; k < single.size(); ++k)
        if (single[k]->clearance(t.center) < single[nearest]->clearance(t.center)) nearest = k;
      const auto [it, inserted] = owner.emplace(t.id, nearest);
      ASSERT_EQ(it->second, nearest) << "track " << t.id << " moved to another obstacle" << where;
      // (ii) no point inside the ellipse is more than 1 m from every real obstacle (0.1 m grid over its box).
      const double reach = t.semi_axes.x();
      for (double x = t.center.x() - reach; x <= t.center.x() + reach; x += 0.1)
        for (double y = t.center.y() - reach; y <= t.center.y() + reach; y += 0.1) {
          const Eigen::Vector3d p(x, y, 0);
          if (!t.contains(p)) continue;
          if (truth->clearance(p) > worst_free) {
            worst_free = truth->clearance(p);
            if (std::getenv("DRIVE_DUMP")) {
              std::printf("worst %.2f at %s track %llu centre %.2f %.2f semi %.2f %.2f n %zu:", worst_free, where.c_str(),
                          (unsigned long long)t.id, t.center.x(), t.center.y(), t.semi_axes.x(), t.semi_axes.y(), t.support.size());
              for (const auto& v : t.support) std::printf(" (%.2f,%.2f)", v.position.x(), v.position.y());
              std::printf("\n");
            }
          }
          if (std::getenv("DRIVE_SURVEY")) continue;
          ASSERT_LE(truth->clearance(p), 1.0) << "track " << t.id << " (semi-axes " << t.semi_axes.head<2>().transpose()
                                               << ") covers free space at " << p.transpose() << where;
        }
    }
    // (iii) start, goal and the vehicle stay free for the planner (ellipses grown by the robot radius).
    if (!tracked.empty()) {
      const auto planned = planner::makeEllipsoidWorld(2, scenario.bounds_min, scenario.bounds_max,
                                                       scenario.robot_radius, asPlannerObstacles(tracked));
      ASSERT_TRUE(planned->isFree(scenario.start)) << "start blocked" << where;
      ASSERT_TRUE(planned->isFree(scenario.goal)) << "goal blocked" << where;
      ASSERT_TRUE(planned->isFree(pose.position)) << "vehicle blocked" << where;
    }
    // (v) every 40 scans the demo's planner (GART) finds a path from the vehicle to the goal on
    // exactly these ellipses ("goal is in collision" was the demo's failure).
    if (step % 40 == 0 && !tracked.empty()) {
      const auto planned = planner::makeEllipsoidWorld(2, scenario.bounds_min, scenario.bounds_max,
                                                       scenario.robot_radius, asPlannerObstacles(tracked));
      planner::PlanProblem problem;
      problem.world = planned.get();
      problem.start = {pose.position, pose.yaw};
      problem.goal = scenario.goal;
      problem.goal_radius = scenario.goal_radius;
      problem.vehicle = scenario.vehicle;
      problem.seed = step + 1;
      problem.time_limit_s = 20.0;
      problem.max_iterations = 200000;
      const auto result = planner::makePlanner("gart")->solve(problem);
      ASSERT_TRUE(result.solved) << "gart found no path" << where;
      ++plans;
    }
    // (iv) the count stays bounded by the obstacles' size, not by the drive's length.
    ASSERT_LE(static_cast<double>(tracked.size()), 2.0 * pieces) << where;
    ++step;
  }
  // The drive saw every obstacle, and the tracked set describes all five.
  std::vector<int> per_obstacle(scenario.obstacles.size(), 0);
  for (const auto& [id, k] : owner) ++per_obstacle[k];
  for (std::size_t k = 0; k < per_obstacle.size(); ++k) EXPECT_GT(per_obstacle[k], 0) << "obstacle " << k << " unseen";
  EXPECT_EQ(plans, 9);
  RecordProperty("tracks", static_cast<int>(tracker.obstacles().size()));
  RecordProperty("peak_tracks", static_cast<int>(peak));
  std::printf("drive: %zu scans, %zu tracks at the end, peak %zu (bound %.0f), farthest covered free point %.2f m\n",
              poses.size(), tracker.obstacles().size(), peak, 2.0 * pieces, worst_free);
}


TEST(Drive, GartTerrain3dEllipsoidsStayOnTheHills) {
  // A short climb toward the first hill of the GART terrain with a 16-ring lidar: every ellipsoid
  // sits on the terrain (hills or ground), its axis tips are within a metre of it, and the start,
  // the goal and the vehicle stay free for the planner. Every scan is checked.
  const auto scenario = planner::loadScenario(kScenarios + "gart_terrain_3d.yaml");
  const auto truth = planner::makeScenarioWorld(withoutRobot(scenario));  // clearance includes the ground
  auto config = sim::RangeSensorConfig::lidar3d(16, 512, -15, 15, 40.0);
  config.walls = false;
  config.range_noise_sigma = 0.02;
  config.invalid_fraction = 0.01;
  sim::RangeSensor sensor(scenario, config);
  DetectorParams params;
  params.beam_spacing = 2 * std::numbers::pi / 512;
  ObstacleDetector detector(params);
  ObstacleTracker tracker(TrackerParams::matching(params));
  const auto poses = posesAlong({{8, 8, 5}, {24, 14, 8}}, 1.0);
  std::size_t step = 0, voxels = 0;
  double farthest_tip = -std::numeric_limits<double>::infinity();  // the farthest axis tip from the terrain
  for (const auto& pose : poses) {
    const auto cloud = sensor.scan(pose);
    const auto detections = detector.detect(cloud.points, cloud.origin);
    const auto& tracked = tracker.update(detections, cloud.origin);
    const std::string where = " at scan " + std::to_string(step);
    // No missed obstacle: every voxel the detector saw in this scan lies inside a tracked ellipsoid, though
    // the tracks keep their evidence on a coarser grid (TrackerParams::voxel_size_3d).
    std::size_t seen = 0, uncovered = 0;
    for (const auto& d : detections)
      for (const auto& s : d.support) {
        const Eigen::Vector3d p = s.position.cast<double>();
        ++seen;
        uncovered += std::none_of(tracked.begin(), tracked.end(), [&](const ObstacleEllipsoid& t) {
          return (p - t.center).norm() <= t.semi_axes[0] && t.contains(p);
        });
      }
    EXPECT_EQ(uncovered, 0u) << "of " << seen << " detection voxels" << where;
    voxels = 0;
    for (const auto& t : tracked) {
      ASSERT_EQ(t.dimensions, 3);
      ASSERT_LE(truth->clearance(t.center), 0.5) << "track " << t.id << " centre " << t.center.transpose() << where;
      for (int k = 0; k < 3; ++k)
        for (double sign : {-1.0, 1.0}) {
          const Eigen::Vector3d tip = t.center + sign * 0.999 * t.semi_axes[k] * t.axes.col(k);
          farthest_tip = std::max(farthest_tip, truth->clearance(tip));
          ASSERT_LE(truth->clearance(tip), 1.0) << "track " << t.id << " reaches free space at " << tip.transpose()
                                                << " (semi-axes " << t.semi_axes.transpose() << ")" << where;
        }
      voxels += t.support.size();
    }
    ASSERT_FALSE(tracked.empty());
    const auto planned = planner::makeEllipsoidWorld(3, scenario.bounds_min, scenario.bounds_max, scenario.robot_radius,
                                                     asPlannerObstacles(tracked));
    ASSERT_TRUE(planned->isFree(scenario.start)) << "start blocked" << where;
    ASSERT_TRUE(planned->isFree(scenario.goal)) << "goal blocked" << where;
    ASSERT_TRUE(planned->isFree(pose.position)) << "vehicle blocked" << where;
    ++step;
  }
  // Pieces are patches of at most 1.5 x 1.5 m: many, but each holds real evidence.
  EXPECT_GE(voxels, 3 * tracker.obstacles().size());
  std::printf("3-D drive: %zu scans, %zu tracks, %zu voxels, farthest axis tip %.2f m from the terrain\n", poses.size(),
              tracker.obstacles().size(), voxels, farthest_tip);
}

}  // namespace
}  // namespace ddsnav::perception
