#include "ddsnav/sim/range_sensor.hpp"

#include "ddsnav/sim/ray_primitives.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

namespace ddsnav::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

void require(bool ok, const std::string& field, const std::string& expected) {
  if (!ok) throw std::invalid_argument("range sensor config: '" + field + "' must be " + expected);
}

}  // namespace

RangeSensorConfig RangeSensorConfig::scanner2d(int beams, double max_range) {
  RangeSensorConfig c;
  c.rings = 1;
  c.columns = beams;
  c.vertical_min_deg = 0.0;
  c.vertical_max_deg = 0.0;
  c.max_range = max_range;
  return c;
}

RangeSensorConfig RangeSensorConfig::lidar3d(int rings, int columns, double vertical_min_deg,
                                             double vertical_max_deg, double max_range) {
  RangeSensorConfig c;
  c.rings = rings;
  c.columns = columns;
  c.vertical_min_deg = vertical_min_deg;
  c.vertical_max_deg = vertical_max_deg;
  c.max_range = max_range;
  return c;
}

void RangeSensorConfig::validate() const {
  require(rings >= 1 && rings <= 4096, "rings", "in [1, 4096]");
  require(columns >= 1 && columns <= 1 << 16, "columns", "in [1, 65536]");
  require(std::isfinite(horizontal_fov_deg) && horizontal_fov_deg > 0.0 && horizontal_fov_deg <= 360.0,
          "horizontal_fov_deg", "in (0, 360]");
  require(std::isfinite(vertical_min_deg) && vertical_min_deg >= -90.0, "vertical_min_deg", ">= -90");
  require(std::isfinite(vertical_max_deg) && vertical_max_deg <= 90.0 && vertical_max_deg >= vertical_min_deg,
          "vertical_max_deg", "in [vertical_min_deg, 90]");
  require(std::isfinite(min_range) && min_range >= 0.0, "min_range", "finite and >= 0");
  require(std::isfinite(max_range) && max_range > min_range, "max_range", "finite and > min_range");
  require(std::isfinite(range_noise_sigma) && range_noise_sigma >= 0.0, "range_noise_sigma", "finite and >= 0");
  require(invalid_fraction >= 0.0 && invalid_fraction <= 1.0, "invalid_fraction", "in [0, 1]");
}

RangeSensor::RangeSensor(const planner::Scenario& scenario, const RangeSensorConfig& config)
    : scenario_(scenario), config_(config), planar_(scenario.dimensions == 2), rng_(config.seed) {
  config_.validate();
  if (planar_ && config_.rings != 1)
    throw std::invalid_argument("range sensor: scenario '" + scenario.name +
                                "' is 2-D, so the sensor must be a planar scanner (rings = 1)");
  for (const auto& obstacle : scenario.obstacles) {
    if (planar_ && obstacle.type == planner::ObstacleType::Hill)
      throw std::invalid_argument("range sensor: scenario '" + scenario.name +
                                  "' is 2-D but has a hill (hills are 3-D only)");
    Primitive p{obstacle, {}, 0.0, std::cos(obstacle.yaw), std::sin(obstacle.yaw)};
    boundingSphere(obstacle, planar_, p.bound_center, p.bound_radius);
    primitives_.push_back(p);
  }

  ring_elevation_.resize(config_.rings);
  for (int r = 0; r < config_.rings; ++r) {
    const double span = config_.vertical_max_deg - config_.vertical_min_deg;
    const double f = config_.rings == 1 ? 0.0 : static_cast<double>(r) / (config_.rings - 1);
    ring_elevation_[r] = planar_ ? 0.0 : (config_.vertical_min_deg + f * span) * kDeg;
  }
  column_azimuth_.resize(config_.columns);
  const bool full_circle = config_.horizontal_fov_deg >= 360.0;
  const double fov = config_.horizontal_fov_deg * kDeg;
  const double step = full_circle ? fov / config_.columns
                                  : (config_.columns == 1 ? 0.0 : fov / (config_.columns - 1));
  for (int c = 0; c < config_.columns; ++c) column_azimuth_[c] = -0.5 * fov + c * step;
  directions_.resize(static_cast<size_t>(config_.rings) * config_.columns);
  ranges_.resize(directions_.size());
}

Eigen::Vector3d RangeSensor::beamDirection(int ring, int column) const {
  return directions_[static_cast<size_t>(ring) * config_.columns + column];
}

void RangeSensor::castPrimitive(const Primitive& p, const Eigen::Vector3d& origin) {
  const int rings = config_.rings, columns = config_.columns;
  Ray ray{origin, {}};
  const Eigen::Vector3d v = p.bound_center - origin;
  const double radius2 = p.bound_radius * p.bound_radius;
  const double v2 = v.squaredNorm();
  auto cast = [&](int r, int c) {
    const size_t i = static_cast<size_t>(r) * columns + c;
    const Eigen::Vector3d& d = directions_[i];
    // Per-beam cull on the bounding sphere: skip when the beam misses it or already hit
    // something closer than where it enters the sphere.
    const double along = v.dot(d);
    const double miss2 = v2 - along * along;  // squared distance of the sphere centre from the beam
    if (miss2 > radius2) return;
    if (along - std::sqrt(radius2 - miss2) >= ranges_[i]) return;
    ray.direction = d;
    const double t = intersect(ray, p.obstacle, p.cos_yaw, p.sin_yaw, planar_, config_.max_range);
    if (t < ranges_[i]) ranges_[i] = t;
  };

  const double dist = v.norm();
  if (dist - p.bound_radius > config_.max_range) return;  // entirely out of range
  if (dist <= p.bound_radius * (1.0 + 1e-9) + 1e-9) {      // sensor inside the bound: every beam
    for (int r = 0; r < rings; ++r)
      for (int c = 0; c < columns; ++c) cast(r, c);
    return;
  }

  // Angular broad phase: the bounding sphere subtends a cone of half-angle alpha; only beams
  // inside that cone (widened by one beam step against rounding) can hit the primitive.
  const double alpha = std::asin(std::min(1.0, p.bound_radius / dist));
  const double elevation = planar_ ? 0.0 : std::asin(std::clamp(v.z() / dist, -1.0, 1.0));
  int r_lo = 0, r_hi = rings - 1;
  if (rings > 1) {
    const double vstep = ring_elevation_[1] - ring_elevation_[0];
    if (vstep > 0.0) {
      r_lo = std::max(0, static_cast<int>(std::floor((elevation - alpha - ring_elevation_[0]) / vstep)));
      r_hi = std::min(rings - 1, static_cast<int>(std::ceil((elevation + alpha - ring_elevation_[0]) / vstep)));
    }
  }
  if (r_lo > r_hi) return;

  const double hstep = columns > 1 ? column_azimuth_[1] - column_azimuth_[0] : 0.0;
  double half_width;  // azimuth half-width of the cone (spherical-cap longitude bound)
  if (std::abs(elevation) + alpha >= 0.5 * std::numbers::pi - 1e-9) {
    half_width = std::numbers::pi;
  } else {
    half_width = std::asin(std::min(1.0, std::sin(alpha) / std::cos(std::abs(elevation))));
  }
  half_width += hstep;
  if (half_width >= std::numbers::pi || hstep <= 0.0) {
    for (int r = r_lo; r <= r_hi; ++r)
      for (int c = 0; c < columns; ++c) cast(r, c);
    return;
  }
  const double azimuth = std::atan2(v.y(), v.x()) - yaw_;
  for (double shift : {-2.0 * std::numbers::pi, 0.0, 2.0 * std::numbers::pi}) {
    const double lo = azimuth - half_width + shift, hi = azimuth + half_width + shift;
    const int c_lo = std::max(0, static_cast<int>(std::floor((lo - column_azimuth_[0]) / hstep)));
    const int c_hi = std::min(columns - 1, static_cast<int>(std::ceil((hi - column_azimuth_[0]) / hstep)));
    for (int r = r_lo; r <= r_hi; ++r)
      for (int c = c_lo; c <= c_hi; ++c) cast(r, c);
  }
}

PointCloud RangeSensor::scan(const SensorPose& pose, double stamp) {
  Eigen::Vector3d origin = pose.position;
  if (planar_) origin.z() = 0.0;
  yaw_ = pose.yaw;
  const int rings = config_.rings, columns = config_.columns;

  // Beam directions for this heading, and the walls as the initial (farthest) hit.
  std::vector<double> cos_az(columns), sin_az(columns);
  for (int c = 0; c < columns; ++c) {
    cos_az[c] = std::cos(column_azimuth_[c] + yaw_);
    sin_az[c] = std::sin(column_azimuth_[c] + yaw_);
  }
  const bool any_bound = config_.walls || (!planar_ && (config_.floor || config_.ceiling));
  for (int r = 0; r < rings; ++r) {
    const double ce = std::cos(ring_elevation_[r]), se = std::sin(ring_elevation_[r]);
    for (int c = 0; c < columns; ++c) {
      const size_t i = static_cast<size_t>(r) * columns + c;
      directions_[i] = {ce * cos_az[c], ce * sin_az[c], planar_ ? 0.0 : se};
      ranges_[i] = any_bound ? exitBounds({origin, directions_[i]}, scenario_.bounds_min, scenario_.bounds_max,
                                          config_.walls, config_.floor, config_.ceiling, planar_)
                             : kNoHit;
    }
  }
  for (const auto& p : primitives_) castPrimitive(p, origin);

  PointCloud cloud;
  cloud.origin = origin;
  cloud.stamp = stamp;
  cloud.points.reserve(ranges_.size());
  std::normal_distribution<double> noise(0.0, config_.range_noise_sigma);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (size_t i = 0; i < ranges_.size(); ++i) {
    double t = ranges_[i];
    if (!(t >= config_.min_range && t <= config_.max_range)) {
      ranges_[i] = kNoHit;
      continue;
    }
    if (config_.invalid_fraction > 0.0 && unit(rng_) < config_.invalid_fraction) {
      const float bad = unit(rng_) < 0.5 ? nan : inf;
      cloud.points.emplace_back(bad, bad, bad);
      continue;
    }
    if (config_.range_noise_sigma > 0.0) t = std::max(0.0, t + noise(rng_));
    cloud.points.push_back((origin + t * directions_[i]).cast<float>());
  }
  return cloud;
}

}  // namespace ddsnav::sim
