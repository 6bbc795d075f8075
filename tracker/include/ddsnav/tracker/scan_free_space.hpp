#pragma once
// The newest planar scan as seen-empty space (docs/tracking.md, "Stopping within observed space"). A map learns
// free space only along rays that hit something: a beam without a return clears nothing, so the open space around a
// vehicle in a field stays "never observed" although the scanner just looked through it. Per bearing bin this keeps
// the nearest return's range from the sensor origin; a bin inside the field of view without a return saw nothing up
// to the sensor's range. No DDS: the tracker component feeds it each cloud.

#include "ddsnav/planner/collision_world.hpp"

#include <vector>

namespace ddsnav::tracker {

class ScanFreeSpace {
 public:
  // `bin_rad`: the bearing bins' width (the scanner's beam spacing or more); `max_range` (m): how far a beam
  // without a return saw nothing; `fov_rad`: the field of view, centred on the heading given with each scan
  // (2 pi: all around). std::invalid_argument for a bin not in (0, pi/8], a range not in (0, 1e5], a field of
  // view not in (0, 2 pi].
  ScanFreeSpace(double bin_rad, double max_range, double fov_rad);

  // Replaces the scan: the points (x, y of each; z ignored) seen from `origin` with the sensor facing `heading`.
  // Non-finite points are skipped; a non-finite origin or heading leaves no scan (nothing seen empty).
  void update(const planner::Vec3& origin, double heading, const std::vector<planner::Vec3>& points);

  // Whether a disc of `radius` at `p` lies in space this scan saw empty: the disc within max_range of the origin and
  // inside the field of view, and every bin its bearings span without a return before the disc's far side (a disc
  // around the origin spans every bearing: an all-round scan only). False before the first scan.
  bool discSeenEmpty(const planner::Vec3& p, double radius) const;

 private:
  std::size_t binOf(double bearing) const;

  double bin_rad_, max_range_, fov_rad_;
  std::vector<float> nearest_;  // per bin, the nearest return's range (infinity: none)
  planner::Vec3 origin_ = planner::Vec3::Zero();
  double heading_ = 0.0;
  bool has_scan_ = false;
};

}  // namespace ddsnav::tracker
