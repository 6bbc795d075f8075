#pragma once
// Factories of the individual planners; makePlanner() (registry.cpp) maps names to them.
// Each factory is defined in the planner's own file (rrt.cpp, rrtstar.cpp, lirrt*.cpp, gart*.cpp, ...).
// planner/CMakeLists.txt scans planner/src/*.cpp for a definition starting a line exactly as
//   std::unique_ptr<Planner> makeGartPlanner() {
// and only then lets the registry call that factory (DDSNAV_HAVE_<NAME>), so the library links while a
// planner is still being written. Define the factory at namespace scope in that form.

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
