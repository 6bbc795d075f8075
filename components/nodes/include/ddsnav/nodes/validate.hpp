#pragma once
// Checks for messages that arrive from other processes, run once where they enter a component (the
// WorldSource callbacks), so a malformed message is dropped with a warning instead of throwing later,
// deep inside a planner or tracker callback.

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/planner/scenario.hpp>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace ddsnav::nodes {

// Empty when every obstacle of `array` can be planned around: header frame `frame`, finite centre,
// semi-axes, orientation and covariance, semi-axes > 0 (x and y only for a planar array, whose z is 0),
// a quaternion of non-zero norm. Otherwise what is wrong with the first bad obstacle, e.g.
// "obstacle 2 (id 7): semi-axis y is -1, expected > 0". An empty `frame` accepts any frame.
std::string checkObstacleArray(const msg::ObstacleArray& array, const std::string& frame);

// Empty when `map` is in frame `frame`, has a positive finite resolution and its bytes are a binary
// OctoMap octree the planner can build a world of for `scenario`; otherwise what is wrong.
std::string checkOccupancyMap(const msg::OccupancyMap& map, const std::string& frame, const planner::Scenario& scenario);

// True when every finite point lies in z = 0 (a planar scanner's cloud). Non-finite points are ignored:
// a scanner reports "no return" beams as NaN/inf, and they say nothing about the cloud's shape.
bool isPlanarCloud(const std::vector<Eigen::Vector3f>& points);

}  // namespace ddsnav::nodes
