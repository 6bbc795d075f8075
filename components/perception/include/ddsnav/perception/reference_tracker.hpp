#pragma once
// The straightforward ObstacleTracker (std::unordered_map evidence, refit of every changed track from
// all its voxels), kept verbatim from before the optimisation as the oracle of
// tracker_equivalence_test: the optimised tracker must produce exactly its tracks. It forgets tracks by
// the same rule (update with a sensor origin), in the plainest way: drop them and rebuild its maps.

#include <ddsnav/perception/obstacle_tracker.hpp>

#include <memory>
#include <span>
#include <vector>

namespace ddsnav::perception::reference {

class ReferenceObstacleTracker {
 public:
  explicit ReferenceObstacleTracker(const perception::TrackerParams& params = {});
  ~ReferenceObstacleTracker();
  ReferenceObstacleTracker(ReferenceObstacleTracker&&) noexcept;
  ReferenceObstacleTracker& operator=(ReferenceObstacleTracker&&) noexcept;

  // Associates one scan's detections (which must carry `support`, as ObstacleDetector's do);
  // returns all tracked obstacles (ids >= 1, in creation order, each with its voxels as `support`).
  const std::vector<perception::ObstacleEllipsoid>& update(std::span<const perception::ObstacleEllipsoid> detections);
  // First drops every track whose voxels are all farther than params.forget_radius from sensor_origin
  // (in the plane for 2-D tracks), then as above.
  const std::vector<perception::ObstacleEllipsoid>& update(std::span<const perception::ObstacleEllipsoid> detections,
                                                           const Eigen::Vector3d& sensor_origin);

  const std::vector<perception::ObstacleEllipsoid>& obstacles() const { return tracks_; }
  const perception::TrackerUpdateStats& lastUpdate() const { return last_; }
  const perception::TrackerParams& params() const { return params_; }

 private:
  struct Evidence;
  void absorb(const perception::ObstacleEllipsoid& detection);
  void forget(const Eigen::Vector3d& sensor_origin);
  void refitChanged();

  perception::TrackerParams params_;
  std::vector<perception::ObstacleEllipsoid> tracks_;
  std::unique_ptr<Evidence> evidence_;
  std::uint64_t next_id_ = 1;
  perception::TrackerUpdateStats last_;
};

}  // namespace ddsnav::perception::reference
