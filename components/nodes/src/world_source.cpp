#include "ddsnav/nodes/world_source.hpp"

#include "ddsnav/nodes/convert.hpp"
#include "ddsnav/nodes/validate.hpp"

#include <spdlog/spdlog.h>

#include <stdexcept>

namespace ddsnav::nodes {

WorldKind parseWorldKind(const std::string& text, const std::string& param) {
  if (text == "obstacles") return WorldKind::Obstacles;
  if (text == "map") return WorldKind::Map;
  if (text == "fused") return WorldKind::Fused;
  if (text == "scenario") return WorldKind::Scenario;
  throw runtime::ParameterError("parameter " + param + ": expected one of obstacles, map, fused, scenario, got '" + text + "'");
}

WorldParameters::WorldParameters(runtime::Parameters& params)
    : kind(parseWorldKind(params.declare<std::string>(
          "world", "obstacles",
          {.doc = "what to plan or check on: perception/obstacles, map/octomap, both fused (docs/world-model.md) or the scenario's exact geometry",
           .choices = {"obstacles", "map", "fused", "scenario"}}))),
      unknown(planner::parseUnknownSpace(params.declare<std::string>(
          "unknown_space", "optimistic",
          {.doc = "how the map's never-observed space counts (map and fused worlds): free or occupied",
           .choices = {"optimistic", "conservative"}}))) {}

WorldSource::WorldSource(runtime::Context& ctx, const WorldParameters& world, const planner::Scenario& scenario)
    : kind_(world.kind), scenario_(scenario), unknown_(world.unknown) {
  // On the component's executor: the arrays and maps are checked there, not on a DDS thread.
  obstacles_sub_ = ctx.subscribe(runtime::topics::obstacles, [this](const msg::ObstacleArray& a) {
    const auto error = checkObstacleArray(a, kWorldFrame);
    std::lock_guard lock(mutex_);
    if (!error.empty()) {
      ++dropped_obstacles_;
      spdlog::warn("perception/obstacles: dropping an array of {} obstacle(s) (stamp {} ns): {}; keeping the {} ({} dropped so far)",
                   a.obstacles().size(), a.header().stamp_ns(), error, obstacles_ ? "last good array" : "world empty",
                   dropped_obstacles_);
      return;
    }
    obstacles_ = a;
  });
  if (kind_ == WorldKind::Map || kind_ == WorldKind::Fused) {
    map_sub_ = ctx.subscribe(runtime::topics::octomap, [this](const msg::OccupancyMap& m) {
      // Parsed outside the lock: a large octree takes a while, and snapshot() must not wait for it.
      const auto error = checkOccupancyMap(m, kWorldFrame, scenario_);
      std::lock_guard lock(mutex_);
      if (!error.empty()) {
        ++dropped_maps_;
        spdlog::warn("map/octomap: dropping a map of {} bytes (stamp {} ns): {}; keeping the {} ({} dropped so far)",
                     m.octree().size(), m.header().stamp_ns(), error, map_ ? "last good map" : "world empty", dropped_maps_);
        return;
      }
      map_ = m;
      structure_stale_ = true;
    });
  }
}

bool WorldSource::available() const {
  std::lock_guard lock(mutex_);
  switch (kind_) {
    case WorldKind::Scenario: return true;
    case WorldKind::Obstacles: return obstacles_.has_value();
    case WorldKind::Map: return map_.has_value();
    // No map yet is all unknown space: free under the optimistic policy (the obstacles alone), blocked
    // under the conservative one (nothing to plan in until the first map).
    case WorldKind::Fused: return obstacles_.has_value() && (map_.has_value() || unknown_ == planner::UnknownSpace::Optimistic);
  }
  return false;
}

bool WorldSource::hasObstacles() const {
  std::lock_guard lock(mutex_);
  return obstacles_.has_value();
}

std::size_t WorldSource::droppedObstacleArrays() const {
  std::lock_guard lock(mutex_);
  return dropped_obstacles_;
}

std::size_t WorldSource::droppedMaps() const {
  std::lock_guard lock(mutex_);
  return dropped_maps_;
}

std::shared_ptr<const planner::CollisionWorld> WorldSource::structureLocked() const {
  if (structure_stale_ && map_) {
    planner::OctoMapWorldOptions options;
    options.unknown_is_occupied = unknown_ == planner::UnknownSpace::Conservative;
    const auto& s = scenario_;
    structure_ = planner::makeOctoMapWorld(s.dimensions, s.bounds_min, s.bounds_max, s.robot_radius, map_->octree(), options);
    structure_stale_ = false;
  }
  return structure_;
}

std::unique_ptr<planner::CollisionWorld> WorldSource::snapshot(const planner::Vec3& robot_position) const {
  const auto& s = scenario_;
  std::lock_guard lock(mutex_);
  switch (kind_) {
    case WorldKind::Scenario:
      return planner::makeScenarioWorld(s);
    case WorldKind::Obstacles:
    case WorldKind::Fused: {
      if (!obstacles_) return nullptr;
      if (kind_ == WorldKind::Fused && !map_ && unknown_ == planner::UnknownSpace::Conservative) return nullptr;
      auto ellipses = toEllipsoidObstacles(*obstacles_);
      if (const auto cleared = clearFootprint(ellipses, robot_position, s.robot_radius, s.dimensions))
        spdlog::debug("ignoring {} obstacle ellipse(s) that cover the robot", cleared);
      auto obstacles = planner::makeEllipsoidWorld(s.dimensions, s.bounds_min, s.bounds_max, s.robot_radius, std::move(ellipses));
      if (kind_ == WorldKind::Obstacles || !map_) return obstacles;
      return planner::makeFusedWorld(structureLocked(), std::move(obstacles));
    }
    case WorldKind::Map: {
      if (!map_) return nullptr;
      planner::OctoMapWorldOptions options;
      options.unknown_is_occupied = unknown_ == planner::UnknownSpace::Conservative;
      return planner::makeOctoMapWorld(s.dimensions, s.bounds_min, s.bounds_max, s.robot_radius, map_->octree(), options);
    }
  }
  return nullptr;
}

}  // namespace ddsnav::nodes
