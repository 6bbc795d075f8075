#include "ddsnav/tracker/path_pieces.hpp"

#include "ddsnav/planner/tree.hpp"

#include <algorithm>
#include <cmath>

namespace ddsnav::tracker {

PathPieces splitPath(const std::vector<planner::State>& path, double piece_length) {
  PathPieces out;
  if (!(piece_length > 0.0) || path.size() < 2 || planner::pathLength(path) <= 1.5 * piece_length) {
    out.piece = path;
    return out;
  }
  double travelled = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const Vec3 edge = path[i].position - path[i - 1].position;
    const double edge_length = edge.norm();
    if (travelled + edge_length < piece_length) {
      travelled += edge_length;
      continue;
    }
    planner::State cut = path[i];
    cut.position = path[i - 1].position + edge * ((piece_length - travelled) / edge_length);
    out.piece.assign(path.begin(), path.begin() + static_cast<std::ptrdiff_t>(i));
    out.piece.push_back(cut);
    out.rest.push_back(cut);
    // The cut at a state itself: that state starts the rest, not a copy next to it.
    const std::size_t next = (path[i].position - cut.position).norm() < 1e-9 ? i + 1 : i;
    out.rest.insert(out.rest.end(), path.begin() + static_cast<std::ptrdiff_t>(next), path.end());
    if (out.rest.size() < 2) out.rest.clear();  // the cut is the path's end after all
    return out;
  }
  out.piece = path;  // unreachable: the path is longer than piece_length
  return out;
}

std::vector<planner::State> continuationPath(const Trajectory& trajectory, double from_time, const std::vector<planner::State>& rest,
                                             double spacing) {
  std::vector<planner::State> out;
  if (trajectory.empty()) return rest;
  const TrajectorySample start = trajectory.at(from_time);
  out.push_back({start.position, start.heading});
  const auto first_after = std::upper_bound(trajectory.samples.begin(), trajectory.samples.end(), from_time,
                                            [](double t, const TrajectorySample& s) { return t < s.time; });
  for (auto it = first_after; it != trajectory.samples.end(); ++it) {
    const bool last = std::next(it) == trajectory.samples.end();
    if (last || (it->position - out.back().position).norm() >= spacing) out.push_back({it->position, it->heading});
  }
  for (const auto& state : rest) {
    if ((state.position - out.back().position).norm() < 1e-9) continue;  // the rest starts where the trajectory ends
    out.push_back(state);
  }
  return out;
}

}  // namespace ddsnav::tracker
