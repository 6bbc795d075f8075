#pragma once
// Synthetic lidar scans of a city block of boxes, for the mapper's tests and benchmark (exact ray-box and
// ray-ground intersections; a beam that hits nothing within sim_range returns no point).

#include "ddsnav/mapper/occupancy_mapper.hpp"

#include <cstdint>
#include <vector>

namespace ddsnav::mapper {

struct Box {
  Point3f min, max;
};

struct CityBlock {
  std::vector<Box> boxes;
  bool ground = true;  // the plane z = 0
};

// Buildings on a street grid covering [-half_extent, half_extent]^2 plus small clutter (poles, cars).
CityBlock makeCityBlock(std::uint32_t seed, double half_extent = 60.0);

struct LidarPattern {
  int rings = 16;          // vertical beams (1 gives a planar 2-D scanner at elevation 0)
  int columns = 1800;      // azimuth steps over 360 deg
  double min_elevation_deg = -15.0;
  double max_elevation_deg = 15.0;
  double sim_range = 60.0;     // beams see this far; points past the mapper's max_range clear space only
  double range_noise = 0.0;    // Gaussian sigma, m
  double invalid_fraction = 0.0;  // fraction of returns replaced by NaN / inf
};

Scan simulateScan(const CityBlock& world, const LidarPattern& lidar, const Point3f& origin, std::uint32_t seed = 1);

}  // namespace ddsnav::mapper
