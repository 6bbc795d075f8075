#pragma once
// Factories of the individual planners; makePlanner() (registry.cpp) maps names to them.
// Each factory is defined in the planner's own file (rrt.cpp, rrtstar.cpp, lirrt*.cpp, gart*.cpp, ...) and
// listed by name in registry.cpp; a new planner adds its line there.

#include "ddsnav/planner/planner.hpp"

#include <memory>

namespace ddsnav::planner {

std::unique_ptr<Planner> makeRrtPlanner();          // rrt.cpp
std::unique_ptr<Planner> makeRrtStarPlanner();      // rrtstar.cpp
std::unique_ptr<Planner> makeRrtControlsPlanner();  // rrt_controls.cpp (Li-RRT paper's baseline)
std::unique_ptr<Planner> makeApgdRrtStarPlanner();  // apgd_rrtstar.cpp
std::unique_ptr<Planner> makeRrrtPlanner();         // rrrt.cpp
std::unique_ptr<Planner> makeDdrrtPlanner();        // ddrrt.cpp
std::unique_ptr<Planner> makeLiRrtPlanner();        // lirrt*.cpp (planner-kino)
std::unique_ptr<Planner> makeGartPlanner();         // gart*.cpp (planner-kino)
std::unique_ptr<Planner> makeGartLazyPlanner();     // gart.cpp: GART with the changes of docs/planners.md

}  // namespace ddsnav::planner
