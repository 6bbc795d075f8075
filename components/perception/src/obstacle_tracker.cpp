#include "ddsnav/perception/obstacle_tracker.hpp"

#include "ddsnav/perception/chi_square.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

namespace ddsnav::perception {
namespace {

// Restricts a covariance to the estimate's dimensions; the unused z block gets a unit entry so
// 3x3 algebra stays well defined in 2-D (and is zeroed again afterwards).
Eigen::Matrix3d active(const Eigen::Matrix3d& m, int dimensions) {
  Eigen::Matrix3d a = m;
  if (dimensions == 2) {
    a.row(2).setZero();
    a.col(2).setZero();
    a(2, 2) = 1.0;
  }
  return a;
}

Eigen::Vector3d planarize(Eigen::Vector3d v, int dimensions) {
  if (dimensions == 2) v.z() = 0.0;
  return v;
}

}  // namespace

void TrackerParams::validate() const {
  if (!(gate_probability > 0.0 && gate_probability < 1.0))
    throw std::invalid_argument("tracker parameter 'gate_probability' must be in (0, 1)");
  if (!(std::isfinite(max_support) && max_support >= 1.0))
    throw std::invalid_argument("tracker parameter 'max_support' must be finite and >= 1");
}

ObstacleTracker::ObstacleTracker(const TrackerParams& params) : params_(params) { params_.validate(); }

const std::vector<ObstacleEllipsoid>& ObstacleTracker::update(std::span<const ObstacleEllipsoid> detections) {
  last_ = {};
  const double gate2 = chiSquareQuantile(params_.gate_probability, 2);
  const double gate3 = chiSquareQuantile(params_.gate_probability, 3);

  // Gated candidate pairs (d2, detection, track).
  std::vector<std::tuple<double, std::size_t, std::size_t>> candidates;
  for (std::size_t d = 0; d < detections.size(); ++d) {
    const auto& det = detections[d];
    if (!det.center.allFinite() || !det.covariance.allFinite() || det.point_count == 0) continue;
    for (std::size_t t = 0; t < tracks_.size(); ++t) {
      const auto& trk = tracks_[t];
      if (trk.dimensions != det.dimensions) continue;
      const Eigen::Vector3d diff = planarize(det.center - trk.center, det.dimensions);
      const Eigen::Matrix3d s = active(det.covariance + trk.covariance, det.dimensions);
      const Eigen::LDLT<Eigen::Matrix3d> ldlt(s);
      if (ldlt.info() != Eigen::Success) continue;
      const double d2 = diff.dot(ldlt.solve(diff));
      if (d2 <= (det.dimensions == 2 ? gate2 : gate3)) candidates.emplace_back(d2, d, t);
    }
  }
  std::sort(candidates.begin(), candidates.end());

  std::vector<bool> detection_used(detections.size(), false), track_used(tracks_.size(), false);
  for (const auto& [d2, d, t] : candidates) {
    if (detection_used[d] || track_used[t]) continue;
    detection_used[d] = track_used[t] = true;
    const auto& det = detections[d];
    auto& trk = tracks_[t];
    const int dims = det.dimensions;
    const double w = support_[t], n = static_cast<double>(det.point_count);

    const Eigen::Matrix3d p = active(centre_covariance_[t], dims);
    const Eigen::Matrix3d r = active(det.covariance / n, dims);
    const Eigen::Matrix3d gain = p * (p + r).inverse();
    const Eigen::Vector3d centre = planarize(trk.center + gain * (det.center - trk.center), dims);
    Eigen::Matrix3d p_new = (Eigen::Matrix3d::Identity() - gain) * p;
    p_new = 0.5 * (p_new + p_new.transpose());

    const double a = w / (w + n), b = n / (w + n);
    const Eigen::Vector3d dt = trk.center - centre, dd = det.center - centre;
    Eigen::Matrix3d extent = a * (trk.covariance + dt * dt.transpose()) + b * (det.covariance + dd * dd.transpose());
    if (dims == 2) {
      extent.row(2).setZero();
      extent.col(2).setZero();
      p_new.row(2).setZero();
      p_new.col(2).setZero();
    }
    trk.center = centre;
    trk.covariance = 0.5 * (extent + extent.transpose());
    trk.point_count += det.point_count;
    updateShapeFromCovariance(trk);
    centre_covariance_[t] = p_new;
    support_[t] = std::min(w + n, params_.max_support);
    ++last_.fused;
  }

  for (std::size_t d = 0; d < detections.size(); ++d) {
    if (detection_used[d]) continue;
    const auto& det = detections[d];
    if (!det.center.allFinite() || !det.covariance.allFinite() || det.point_count == 0) continue;
    ObstacleEllipsoid trk = det;
    trk.id = next_id_++;
    tracks_.push_back(trk);
    const double n = static_cast<double>(det.point_count);
    centre_covariance_.push_back(det.covariance / n);
    support_.push_back(std::min(n, params_.max_support));
    ++last_.created;
  }
  return tracks_;
}

}  // namespace ddsnav::perception
