#pragma once
// Keeps obstacles across scans: each new ellipsoid is fused into the tracked one for the same
// obstacle, so ids are stable and the set grows as the vehicle discovers the world.
//
//   ObstacleTracker tracker;
//   for (each cloud) { auto& world = tracker.update(detector.detect(cloud.points, cloud.origin)); }
//
// Association (per update): a detection D and a track T of the same dimension are candidates when
//   d2 = (c_D - c_T)^T (S_D + S_T)^-1 (c_D - c_T) <= chi2_quantile(gate_probability, d),
// S the extent covariances: two descriptions of one obstacle differ by at most their combined
// spread. Candidate pairs are taken greedily by increasing d2, each detection and track at most
// once (global nearest neighbour). An unmatched detection starts a track with a new id; tracks are
// never dropped (the world is static; a track not seen again keeps its last estimate).
//
// Fusion (Kalman-style, per matched pair; n = supporting points, w = a track's capped support):
//   centre:   P = S_T / w, R = S_D / n, K = P (P + R)^-1, c = c_T + K (c_D - c_T), P' = (I - K) P
//   extent:   S = a (S_T + (c_T - c)(c_T - c)^T) + b (S_D + (c_D - c)(c_D - c)^T),
//             a = w / (w + n), b = n / (w + n)        (moment matching: the union of both views)
//   support:  w' = min(w + n, max_support)
// so repeated views of the same surface keep the ellipsoid, new faces of an obstacle grow it,
// and the centre settles with the noise averaged out.

#include <ddsnav/perception/obstacle.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace ddsnav::perception {

struct TrackerParams {
  double gate_probability = 0.99;  // Mahalanobis gate, as a chi-square probability
  double max_support = 5000.0;     // cap on a track's weight so it keeps adapting
  void validate() const;           // throws std::invalid_argument naming the bad parameter
};

struct TrackerUpdateStats {
  std::size_t fused = 0;       // detections merged into an existing track
  std::size_t created = 0;     // new tracks
};

class ObstacleTracker {
 public:
  explicit ObstacleTracker(const TrackerParams& params = {});

  // Fuses one scan's detections; returns all tracked obstacles (ids >= 1, in creation order).
  const std::vector<ObstacleEllipsoid>& update(std::span<const ObstacleEllipsoid> detections);

  const std::vector<ObstacleEllipsoid>& obstacles() const { return tracks_; }
  const TrackerUpdateStats& lastUpdate() const { return last_; }

 private:
  TrackerParams params_;
  std::vector<ObstacleEllipsoid> tracks_;
  std::vector<Eigen::Matrix3d> centre_covariance_;  // P per track
  std::vector<double> support_;                     // w per track
  std::uint64_t next_id_ = 1;
  TrackerUpdateStats last_;
};

}  // namespace ddsnav::perception
