// For the tools that replay a mission's recording offline (ddsnav resmooth, ddsnav-replan-replay): a recorded
// message decoded into its sample type, and the components' fused world rebuilt from recorded inputs.
#pragma once

#include "ddsnav/nodes/world_source.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/collision_world.hpp>
#include <ddsnav/record/mcap.hpp>

#include <memory>
#include <optional>
#include <vector>

namespace ddsnav::bench {

// The message as a T; nothing when its bytes are not a T's CDR.
template <class T>
std::optional<T> decodeRecorded(const record::MessageView& view) {
  T sample;
  if (!msg::type_support<T>().deserialize(view.data.data(), view.data.size(), &sample)) return std::nullopt;
  return sample;
}

// The 3-D sensor view a component with the default world parameters blocks, seen from `origin`, the goal region
// (`goal`, `goal_radius` grown by the robot radius) exempt.
inline planner::SensorView recordedSensorView(const planner::Scenario& scenario, const planner::Vec3& origin, const planner::Vec3& goal,
                                              double goal_radius) {
  planner::SensorView view = nodes::sensorViewOf(scenario, nodes::WorldParameters{});
  view.origin = origin;
  view.exempt_center = goal;
  view.exempt_radius = goal_radius + scenario.robot_radius;
  return view;
}

// The fused world: the ellipses (already cleared around the robot) alone without a map; with one, fused with it and,
// when `view` is given, seen through it.
inline std::unique_ptr<planner::CollisionWorld> recordedFusedWorld(const planner::Scenario& scenario,
                                                                   std::shared_ptr<const planner::CollisionWorld> map,
                                                                   const std::vector<planner::EllipsoidObstacle>& ellipses,
                                                                   const std::optional<planner::SensorView>& view) {
  auto world = planner::makeEllipsoidWorld(scenario.dimensions, scenario.bounds_min, scenario.bounds_max, scenario.robot_radius, ellipses);
  if (!map) return world;
  auto fused = planner::makeFusedWorld(std::move(map), std::move(world));
  return view ? planner::makeSensorViewWorld(std::move(fused), *view) : std::move(fused);
}

}  // namespace ddsnav::bench
