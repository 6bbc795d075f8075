#pragma once
// Reference maps built with OctoMap's own OcTree::insertPointCloud, and comparisons against them.
#include "ddsnav/mapper/occupancy_mapper.hpp"

#include <octomap/OcTree.h>

#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace ddsnav::mapper::testing {

inline octomap::Pointcloud toOctomapCloud(const Scan& scan, const MapperConfig& config) {
  octomap::Pointcloud cloud;
  for (const Point3f& p : scan.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    cloud.push_back(p.x, p.y, config.dimensions == 2 ? static_cast<float>(config.slab_z) : p.z);
  }
  return cloud;
}

inline octomap::point3d toOrigin(const Scan& scan, const MapperConfig& config) {
  return {scan.origin.x, scan.origin.y, config.dimensions == 2 ? static_cast<float>(config.slab_z) : scan.origin.z};
}

// The whole tree with log-odds (.ot format): equal strings mean equal structure and equal values.
inline std::string fullBytes(const octomap::OcTree& tree) {
  std::ostringstream s;
  tree.write(s);
  return s.str();
}

struct QueryMismatch {
  int point_mismatches = 0;
  int ray_mismatches = 0;
};

// `points` random point queries (search) and `rays` castRay queries inside [lo, hi].
inline QueryMismatch compareQueries(const octomap::OcTree& a, const octomap::OcTree& b, const octomap::point3d& lo,
                                    const octomap::point3d& hi, int points, int rays, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> ux(lo.x(), hi.x()), uy(lo.y(), hi.y()), uz(lo.z(), hi.z());
  std::uniform_real_distribution<float> angle(-3.14159f, 3.14159f);
  QueryMismatch m;
  for (int i = 0; i < points; ++i) {
    const double x = ux(rng), y = uy(rng), z = uz(rng);
    const octomap::OcTreeNode* na = a.search(x, y, z);
    const octomap::OcTreeNode* nb = b.search(x, y, z);
    const bool same = (na == nullptr) == (nb == nullptr) &&
                      (na == nullptr || (a.isNodeOccupied(na) == b.isNodeOccupied(nb) &&
                                         na->getLogOdds() == nb->getLogOdds()));
    if (!same) ++m.point_mismatches;
  }
  for (int i = 0; i < rays; ++i) {
    const octomap::point3d origin(ux(rng), uy(rng), uz(rng));
    const float yaw = angle(rng), pitch = angle(rng) * (lo.z() == hi.z() ? 0.0f : 0.3f);
    const octomap::point3d dir(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
    octomap::point3d end_a, end_b;
    const bool hit_a = a.castRay(origin, dir, end_a, /*ignoreUnknownCells=*/true, 25.0);
    const bool hit_b = b.castRay(origin, dir, end_b, true, 25.0);
    if (hit_a != hit_b || !(end_a == end_b)) ++m.ray_mismatches;
  }
  return m;
}

}  // namespace ddsnav::mapper::testing
