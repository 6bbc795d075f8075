#include "ddsnav/nodes/ground_truth.hpp"

#include <ddsnav/planner/collision_world.hpp>

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace ddsnav::nodes {

namespace {

std::string where(const planner::Vec3& p, int dimensions) {
  return dimensions == 2 ? fmt::format("({:g}, {:g})", p.x(), p.y()) : fmt::format("({:g}, {:g}, {:g})", p.x(), p.y(), p.z());
}

std::string obstacleName(const planner::Scenario& s, int id) {
  static constexpr std::array<const char*, 4> kTypes{"box", "sphere", "ellipsoid", "hill"};
  if (id < 0 || id >= static_cast<int>(s.obstacles.size())) return "an obstacle";
  const auto& o = s.obstacles[static_cast<std::size_t>(id)];
  return fmt::format("obstacle #{} ({} at {})", id + 1, kTypes[static_cast<std::size_t>(o.type)], where(o.center, s.dimensions));
}

// "inside obstacle #3 (sphere at (20, 14))" when p is inside one, else empty.
std::string inside(const planner::Scenario& s, const planner::CollisionWorld& point_world, const planner::Vec3& p) {
  for (const auto& near : point_world.obstaclesNear(p, 0.0))
    if (near.distance <= 0.0) return "inside " + obstacleName(s, near.id);
  return "";
}

}  // namespace

GoalFeasibility checkGoalFeasible(const planner::Scenario& scenario, std::size_t max_cells) {
  const int dims = scenario.dimensions;
  const auto world = planner::makeScenarioWorld(scenario);
  planner::Scenario point_scenario = scenario;
  point_scenario.robot_radius = 0.0;
  const auto point_world = planner::makeScenarioWorld(point_scenario);
  GoalFeasibility out;
  if (!world->isFree(scenario.start)) {
    const std::string in = inside(scenario, *point_world, scenario.start);
    out.feasible = false;
    out.why = fmt::format("the start {} is in collision{} (robot radius {:g} m)", where(scenario.start, dims),
                          in.empty() ? " or too close to the bounds" : " (" + in + ")", scenario.robot_radius);
    return out;
  }

  // The grid: cells of side h over the bounds, at most max_cells of them.
  const planner::Vec3 lo = scenario.bounds_min, hi = scenario.bounds_max;
  const planner::Vec3 extent = hi - lo;
  const double volume = dims == 2 ? extent.x() * extent.y() : extent.x() * extent.y() * extent.z();
  // Cells no finer than a quarter of the robot radius: finer ones would only cost time.
  double h = std::max(0.25 * scenario.robot_radius, std::pow(volume / static_cast<double>(std::max<std::size_t>(max_cells, 1)), 1.0 / dims));
  if (!(h > 0.0) || !std::isfinite(h)) h = 1.0;
  std::array<std::int64_t, 3> n{1, 1, 1};
  for (int a = 0; a < dims; ++a) n[a] = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(extent[a] / h)));
  while (static_cast<double>(n[0]) * n[1] * n[2] > static_cast<double>(max_cells) * 1.01) {  // rounding up can overshoot
    h *= 1.05;
    for (int a = 0; a < dims; ++a) n[a] = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(extent[a] / h)));
  }
  // Optimistic free space: a centre is within one cell diagonal of every point of its cell.
  planner::Scenario shrunk = scenario;
  shrunk.robot_radius = std::max(0.0, scenario.robot_radius - h * std::sqrt(static_cast<double>(dims)));
  const auto optimistic = planner::makeScenarioWorld(shrunk);
  auto centre = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    planner::Vec3 c(lo.x() + (i + 0.5) * h, lo.y() + (j + 0.5) * h, dims == 3 ? lo.z() + (k + 0.5) * h : 0.0);
    return planner::Vec3(c.cwiseMin(hi).cwiseMax(lo));
  };
  auto cellOf = [&](const planner::Vec3& p) {
    std::array<std::int64_t, 3> c{0, 0, 0};
    for (int a = 0; a < dims; ++a) c[a] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((p[a] - lo[a]) / h)), 0, n[a] - 1);
    return c;
  };
  auto index = [&](std::int64_t i, std::int64_t j, std::int64_t k) { return static_cast<std::size_t>((k * n[1] + j) * n[0] + i); };

  // Goal cells: centres within goal_radius plus a cell diagonal of the goal, free on the optimistic grid.
  const double goal_reach = scenario.goal_radius + h * std::sqrt(static_cast<double>(dims));
  std::vector<std::uint8_t> state(static_cast<std::size_t>(n[0] * n[1] * n[2]), 0);  // 0 unknown, 1 blocked, 2 free, 3 reached
  auto freeCell = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    auto& s = state[index(i, j, k)];
    if (s == 0) s = optimistic->isFree(centre(i, j, k)) ? 2 : 1;
    return s >= 2;
  };
  bool goal_region_free = false;
  {
    const auto c_lo = cellOf(scenario.goal - planner::Vec3::Constant(goal_reach));
    const auto c_hi = cellOf(scenario.goal + planner::Vec3::Constant(goal_reach));
    for (std::int64_t k = c_lo[2]; k <= c_hi[2] && !goal_region_free; ++k)
      for (std::int64_t j = c_lo[1]; j <= c_hi[1] && !goal_region_free; ++j)
        for (std::int64_t i = c_lo[0]; i <= c_hi[0] && !goal_region_free; ++i)
          goal_region_free = (centre(i, j, k) - scenario.goal).norm() <= goal_reach && freeCell(i, j, k);
  }
  if (!goal_region_free) {
    const std::string in = inside(scenario, *point_world, scenario.goal);
    out.feasible = false;
    out.why = fmt::format("the goal {} is {}: no collision-free state within goal_radius ({:g} m) of it", where(scenario.goal, dims),
                          in.empty() ? "blocked" : in, scenario.goal_radius);
    return out;
  }

  // Flood fill from the start over the optimistic free cells (3^d - 1 neighbours).
  std::vector<std::array<std::int64_t, 3>> frontier{cellOf(scenario.start)};
  const auto s0 = frontier.front();
  if (!freeCell(s0[0], s0[1], s0[2])) state[index(s0[0], s0[1], s0[2])] = 2;  // the start is free (checked above)
  state[index(s0[0], s0[1], s0[2])] = 3;
  const std::int64_t dk = dims == 3 ? 1 : 0;
  while (!frontier.empty()) {
    const auto c = frontier.back();
    frontier.pop_back();
    if ((centre(c[0], c[1], c[2]) - scenario.goal).norm() <= goal_reach) return out;  // reached the goal region
    for (std::int64_t k = c[2] - dk; k <= c[2] + dk; ++k)
      for (std::int64_t j = c[1] - 1; j <= c[1] + 1; ++j)
        for (std::int64_t i = c[0] - 1; i <= c[0] + 1; ++i) {
          if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) continue;
          if (state[index(i, j, k)] == 3 || !freeCell(i, j, k)) continue;
          state[index(i, j, k)] = 3;
          frontier.push_back({i, j, k});
        }
  }
  out.feasible = false;
  out.why = fmt::format("the goal {} is unreachable: free space does not connect it to the start {} (checked on a {:.2g} m grid "
                        "of the scenario's true obstacles, robot radius {:g} m)",
                        where(scenario.goal, dims), where(scenario.start, dims), h, scenario.robot_radius);
  return out;
}

std::optional<ClosestApproach> closestApproach(const planner::Scenario& scenario, const std::vector<planner::Vec3>& track) {
  if (track.empty()) return std::nullopt;
  const auto world = scenario.obstacles.empty() ? nullptr : planner::makeScenarioWorld(scenario);
  const int dims = scenario.dimensions == 3 ? 3 : 2;
  ClosestApproach best{std::numeric_limits<double>::infinity(), 0, false};
  for (std::size_t i = 0; i < track.size(); ++i) {
    if (world) {
      const double c = world->clearance(track[i]);
      if (c < best.clearance_m) best = {c, i, false};
    }
    // The bounds' faces, as the scenario format's validity rule has them: the robot lies inside the bounds.
    for (int a = 0; a < dims; ++a) {
      const double c = std::min(track[i][a] - scenario.bounds_min[a], scenario.bounds_max[a] - track[i][a]) - scenario.robot_radius;
      if (c < best.clearance_m) best = {c, i, true};
    }
  }
  if (!std::isfinite(best.clearance_m)) return std::nullopt;
  return best;
}

std::optional<double> minTrueClearance(const planner::Scenario& scenario, const std::vector<planner::Vec3>& track) {
  const auto closest = closestApproach(scenario, track);
  return closest ? std::optional<double>(closest->clearance_m) : std::nullopt;
}

}  // namespace ddsnav::nodes
