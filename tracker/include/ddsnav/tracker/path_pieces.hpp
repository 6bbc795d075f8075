#pragma once
// A long path is smoothed and flown a piece at a time (a receding horizon): the first piece becomes the
// trajectory, and the next one is smoothed — continuing the trajectory from a point ahead of the vehicle,
// at its speed and heading — while the vehicle flies the rest of the current one. A 1.8 km AUV path
// smoothed whole is 21 000 samples (1.5 MB a message) for every replan, although only its first few hundred
// metres are flown before the next replan. See docs/tracking.md, "Long paths, a piece at a time".

#include "ddsnav/planner/planner.hpp"
#include "ddsnav/tracker/trajectory.hpp"

#include <vector>

namespace ddsnav::tracker {

struct PathPieces {
  std::vector<planner::State> piece;  // smoothed now; ends where `rest` starts
  std::vector<planner::State> rest;   // empty when `piece` is the whole path
};

// Splits `path` at arc length `piece_length` (at a point on the edge that reaches it). A path no longer
// than 1.5 x piece_length is not split (a short rest would be smoothed at once anyway), nor is any path
// when piece_length <= 0.
PathPieces splitPath(const std::vector<planner::State>& path, double piece_length);

// The path that continues `trajectory` from its sample at `from_time`: the trajectory's positions from
// there to its end, at least `spacing` apart (its first and last position kept), then `rest` (the path
// after the trajectory's end, starting there).
std::vector<planner::State> continuationPath(const Trajectory& trajectory, double from_time, const std::vector<planner::State>& rest,
                                             double spacing);

}  // namespace ddsnav::tracker
