#pragma once
// Pictures of a planning run as SVG: the scenario's obstacles (exact shapes), the search tree, the path,
// start and goal. 2-D: one top view. 3-D: a top view (x-y) beside a side view (x-z).

#include "ddsnav/planner/collision_world.hpp"
#include "ddsnav/planner/planner.hpp"
#include "ddsnav/planner/scenario.hpp"

#include <string>
#include <vector>

namespace ddsnav::planner {

// An extra line drawn over the world: a trajectory, a driven track, another planner's path.
struct SvgPolyline {
  std::vector<Vec3> points;
  std::string colour = "#9467bd";  // any CSS colour
  double width_px = 1.5;
  bool dashed = false;
  std::string label;               // shown in the legend when not empty
};

struct SvgScene {
  const Scenario* scenario = nullptr;  // world geometry, start, goal (required)
  std::vector<TreeEdge> tree;          // drawn thin and grey
  std::vector<State> path;             // drawn thick
  std::string title;                   // printed on top
  // Obstacles as another source sees them (perception's ellipses): drawn as outlines over the world.
  std::vector<EllipsoidObstacle> ellipses;
  std::vector<SvgPolyline> polylines;  // drawn over the path, in order
};

// The SVG document as text.
std::string renderSvg(const SvgScene& scene, int width_px = 900);

// Writes renderSvg(scene) to `path`; throws std::runtime_error naming the file when it cannot.
void writeSvg(const std::string& path, const SvgScene& scene, int width_px = 900);

}  // namespace ddsnav::planner
