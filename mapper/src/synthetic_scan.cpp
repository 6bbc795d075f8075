#include "ddsnav/mapper/synthetic_scan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

namespace ddsnav::mapper {
namespace {

// Entry distance of the ray o + t d into the box, or +inf (slab method).
double rayBox(const double o[3], const double d[3], const Box& b) {
  const double lo[3] = {b.min.x, b.min.y, b.min.z}, hi[3] = {b.max.x, b.max.y, b.max.z};
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (std::abs(d[i]) < 1e-12) {
      if (o[i] < lo[i] || o[i] > hi[i]) return std::numeric_limits<double>::infinity();
      continue;
    }
    double a = (lo[i] - o[i]) / d[i], c = (hi[i] - o[i]) / d[i];
    if (a > c) std::swap(a, c);
    t0 = std::max(t0, a);
    t1 = std::min(t1, c);
    if (t0 > t1) return std::numeric_limits<double>::infinity();
  }
  return t0;
}

}  // namespace

CityBlock makeCityBlock(std::uint32_t seed, double half_extent) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  CityBlock city;
  const double pitch = 14.0, street = 5.0;
  for (double bx = -half_extent; bx + pitch <= half_extent; bx += pitch) {
    for (double by = -half_extent; by + pitch <= half_extent; by += pitch) {
      if (std::abs(bx + pitch / 2) < pitch && std::abs(by + pitch / 2) < pitch) continue;  // keep the sensor's square open
      const double w = (pitch - street) * (0.5 + 0.5 * u(rng)), l = (pitch - street) * (0.5 + 0.5 * u(rng));
      const double h = 3.0 + 12.0 * u(rng);
      const float x0 = float(bx + street / 2), y0 = float(by + street / 2);
      city.boxes.push_back({{x0, y0, 0.0f}, {float(x0 + w), float(y0 + l), float(h)}});
      // Street clutter: a pole and a car-sized box per block.
      const float px = float(bx + 1.0 + u(rng)), py = float(by + pitch * u(rng));
      city.boxes.push_back({{px, py, 0.0f}, {px + 0.3f, py + 0.3f, 4.0f}});
      const float cx = float(bx + pitch * u(rng)), cy = float(by + 0.5 + u(rng));
      city.boxes.push_back({{cx, cy, 0.0f}, {cx + 4.2f, cy + 1.8f, 1.5f}});
    }
  }
  return city;
}

Scan simulateScan(const CityBlock& world, const LidarPattern& lidar, const Point3f& origin, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, lidar.range_noise > 0.0 ? lidar.range_noise : 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Scan scan;
  scan.origin = origin;
  scan.points.reserve(static_cast<std::size_t>(lidar.rings) * lidar.columns);
  const double o[3] = {origin.x, origin.y, origin.z};
  const double deg = std::numbers::pi / 180.0;
  for (int r = 0; r < lidar.rings; ++r) {
    const double elevation =
        lidar.rings == 1 ? 0.0
                         : (lidar.min_elevation_deg +
                            (lidar.max_elevation_deg - lidar.min_elevation_deg) * r / (lidar.rings - 1)) * deg;
    for (int c = 0; c < lidar.columns; ++c) {
      const double azimuth = 2.0 * std::numbers::pi * c / lidar.columns;
      const double d[3] = {std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                           std::sin(elevation)};
      double t = lidar.sim_range;
      bool hit = false;
      if (world.ground && d[2] < -1e-9) {
        const double tg = -o[2] / d[2];
        if (tg > 0.0 && tg < t) t = tg, hit = true;
      }
      for (const Box& b : world.boxes) {
        const double tb = rayBox(o, d, b);
        if (tb > 0.0 && tb < t) t = tb, hit = true;
      }
      if (!hit) continue;
      if (lidar.range_noise > 0.0) t = std::max(0.05, t + noise(rng));
      Point3f p{float(o[0] + t * d[0]), float(o[1] + t * d[1]), float(o[2] + t * d[2])};
      if (lidar.invalid_fraction > 0.0 && u(rng) < lidar.invalid_fraction) {
        p.x = (c % 2 == 0) ? std::numeric_limits<float>::quiet_NaN() : std::numeric_limits<float>::infinity();
      }
      scan.points.push_back(p);
    }
  }
  return scan;
}

}  // namespace ddsnav::mapper
