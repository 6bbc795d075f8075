#include "ddsnav/tracker/scan_free_space.hpp"

#include "ddsnav/tracker/vehicle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ddsnav::tracker {

ScanFreeSpace::ScanFreeSpace(double bin_rad, double max_range, double fov_rad) : bin_rad_(bin_rad), max_range_(max_range), fov_rad_(fov_rad) {
  if (!(bin_rad > 0.0 && bin_rad <= M_PI / 8)) throw std::invalid_argument("ScanFreeSpace: the bin width must be in (0, pi/8] rad");
  if (!(max_range > 0.0 && max_range <= 1e5)) throw std::invalid_argument("ScanFreeSpace: max_range must be in (0, 1e5] m");
  if (!(fov_rad > 0.0 && fov_rad <= 2 * M_PI)) throw std::invalid_argument("ScanFreeSpace: the field of view must be in (0, 2 pi] rad");
  nearest_.assign(static_cast<std::size_t>(std::ceil(2 * M_PI / bin_rad_)), std::numeric_limits<float>::infinity());
}

std::size_t ScanFreeSpace::binOf(double bearing) const {
  const double turned = bearing - 2 * M_PI * std::floor(bearing / (2 * M_PI));  // [0, 2 pi)
  return std::min(nearest_.size() - 1, static_cast<std::size_t>(turned / bin_rad_));
}

void ScanFreeSpace::update(const planner::Vec3& origin, double heading, const std::vector<planner::Vec3>& points) {
  std::fill(nearest_.begin(), nearest_.end(), std::numeric_limits<float>::infinity());
  has_scan_ = origin.allFinite() && std::isfinite(heading);
  if (!has_scan_) return;
  origin_ = origin;
  heading_ = heading;
  for (const planner::Vec3& p : points) {
    if (!p.allFinite()) continue;
    const double dx = p.x() - origin.x(), dy = p.y() - origin.y();
    float& nearest = nearest_[binOf(std::atan2(dy, dx))];
    nearest = std::min(nearest, static_cast<float>(std::hypot(dx, dy)));
  }
}

bool ScanFreeSpace::discSeenEmpty(const planner::Vec3& p, double radius) const {
  if (!has_scan_ || !p.allFinite() || !(radius >= 0.0)) return false;
  const double dx = p.x() - origin_.x(), dy = p.y() - origin_.y();
  const double distance = std::hypot(dx, dy);
  const double far_side = distance + radius;
  if (far_side > max_range_) return false;
  if (distance <= radius) {
    // Around the sensor itself every bearing is the disc's: seen all round, or not at all.
    if (fov_rad_ < 2 * M_PI) return false;
    return std::all_of(nearest_.begin(), nearest_.end(), [&](float r) { return r >= far_side; });
  }
  const double bearing = std::atan2(dy, dx);
  const double half_width = std::asin(radius / distance);
  if (fov_rad_ < 2 * M_PI && std::abs(wrapAngle(bearing - heading_)) + half_width > 0.5 * fov_rad_) return false;
  // Every bin the disc's bearings touch: a return anywhere there before the far side may be the disc's obstacle.
  const auto bins = static_cast<long>(std::ceil(half_width / bin_rad_)) + 1;
  const std::size_t centre = binOf(bearing);
  const long n = static_cast<long>(nearest_.size());
  for (long k = -bins; k <= bins; ++k)
    if (nearest_[static_cast<std::size_t>(((static_cast<long>(centre) + k) % n + n) % n)] < far_side) return false;
  return true;
}

}  // namespace ddsnav::tracker
