#pragma once
// A procedurally generated 3-D city block (street canyon with buildings, parked cars, trees,
// poles and pedestrians on a flat floor) for perception tests and benchmarks.

#include <ddsnav/planner/scenario.hpp>

#include <cstdint>

namespace ddsnav::sim {

// About 120 x 120 x 30 m, a street along x through the origin; deterministic in `seed`.
// A sensor at (0, 0, 1.8) sees buildings on both sides and everything on the street.
planner::Scenario makeCityBlock(std::uint64_t seed = 1);

}  // namespace ddsnav::sim
