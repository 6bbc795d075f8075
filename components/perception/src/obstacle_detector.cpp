#include "ddsnav/perception/obstacle_detector.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ddsnav::perception {
namespace {

void require(bool ok, const char* name, const char* expected) {
  if (!ok) throw std::invalid_argument(std::string("perception parameter '") + name + "' must be " + expected);
}

bool finitePositive(double v) { return std::isfinite(v) && v > 0.0; }

const DetectorParams& validated(const DetectorParams& params) {
  params.validate();
  return params;
}

class StageTimer {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - last_).count();
    last_ = now;
    return ms;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

}  // namespace

void DetectorParams::validate() const {
  require(std::isfinite(voxel_size) && voxel_size >= 0.001 && voxel_size <= 100.0, "voxel_size", "in [0.001, 100] m");
  require(finitePositive(max_range) && max_range <= 1e5, "max_range", "in (0, 1e5] m");
  require(std::isfinite(ground_z), "ground_z", "finite");
  require(std::isfinite(cluster_tolerance) && cluster_tolerance >= 0.001 && cluster_tolerance <= 100.0,
          "cluster_tolerance", "in [0.001, 100] m");
  require(min_cluster_size >= 1, "min_cluster_size", ">= 1");
  require(max_cluster_size >= min_cluster_size, "max_cluster_size", ">= min_cluster_size");
  require(std::isfinite(gap_min_width) && gap_min_width >= 0.0, "gap_min_width", "finite and >= 0");
  require(finitePositive(beam_spacing) && beam_spacing < 1.0, "beam_spacing", "in (0, 1) rad");
  require(std::isfinite(gap_min_beams) && gap_min_beams >= 1.0, "gap_min_beams", ">= 1");
  require(std::isfinite(max_segment_length) && max_segment_length >= 0.0, "max_segment_length",
          "finite and >= 0 m (0: never cut)");
  require(std::isfinite(max_segment_width) && max_segment_width >= 0.0, "max_segment_width",
          "finite and >= 0 m (0: as max_segment_length)");
  require(std::isfinite(max_segment_width_3d) && max_segment_width_3d >= 0.0, "max_segment_width_3d",
          "finite and >= 0 m (0: as max_segment_length)");
  require(probability > 0.0 && probability < 1.0, "probability", "in (0, 1)");
  require(std::isfinite(range_noise_sigma) && range_noise_sigma >= 0.0, "range_noise_sigma", "finite and >= 0");
  require(max_points >= 1 && max_points < (std::size_t{1} << 31), "max_points", "in [1, 2^31)");
  require(std::isfinite(structure_extent) && structure_extent >= 0.0, "structure_extent", "finite and >= 0 m (0: no structure)");
}

ObstacleDetector::ObstacleDetector(const DetectorParams& params)
    : params_(validated(params)),
      voxel_grid_(static_cast<float>(params.voxel_size)),
      clusterer_(ClusterParams{params.cluster_tolerance, params.min_cluster_size, params.max_cluster_size}) {}

std::vector<ObstacleEllipsoid> ObstacleDetector::detect(std::span<const Eigen::Vector3f> points,
                                                        const Eigen::Vector3d& sensor_origin, int dimensions) {
  stats_ = {};
  stats_.input_points = points.size();
  if (!sensor_origin.allFinite()) throw std::invalid_argument("perception: sensor origin is not finite");
  if (points.size() > params_.max_points)
    throw std::invalid_argument("perception: cloud of " + std::to_string(points.size()) +
                                " points exceeds max_points = " + std::to_string(params_.max_points));
  if (dimensions != 0 && dimensions != 2 && dimensions != 3)
    throw std::invalid_argument("perception: dimensions must be 0 (infer), 2 or 3");
  StageTimer timer;

  // 1. Finite points within range (checked once, here).
  const Eigen::Vector3f origin = sensor_origin.cast<float>();
  const float max_range2 = static_cast<float>(params_.max_range * params_.max_range);
  finite_.clear();
  finite_.reserve(points.size());
  bool all_planar = true;
  for (const auto& p : points) {
    const float d2 = (p - origin).squaredNorm();
    if (!(d2 <= max_range2)) continue;  // also false for NaN / inf
    finite_.push_back(p);
    all_planar &= p.z() == 0.0f;
  }
  stats_.dropped_invalid = points.size() - finite_.size();
  if (dimensions == 0) dimensions = all_planar ? 2 : 3;
  if (dimensions == 2)
    for (auto& p : finite_) p.z() = 0.0f;
  stats_.ms_filter = timer.lap();

  // 2. + 3. Voxel grid, then ground removal.
  voxel_grid_.filter(finite_, voxels_);
  stats_.voxels = voxels_.size();
  if (dimensions == 3 && params_.remove_ground) {
    const float ground = static_cast<float>(params_.ground_z);
    std::erase_if(voxels_, [&](const Eigen::Vector3f& v) { return v.z() <= ground; });
    stats_.ground_voxels = stats_.voxels - voxels_.size();
  }
  stats_.ms_voxel = timer.lap();

  // 4. Euclidean clusters.
  clusterer_.extract(voxels_, clusters_);
  stats_.clusters = clusters_.size();
  stats_.clustered_points = clusters_.indices.size();
  structure_.clear();
  if (params_.structure_extent > 0.0) separateStructure();
  stats_.ms_cluster = timer.lap();

  // 5. Split at see-through gaps.
  if (params_.split_gaps) {
    splitGaps(sensor_origin);
  } else {
    parts_ = clusters_;
  }
  stats_.parts = parts_.size();

  // 6. Bound the size of one ellipsoid: a 22 m wall is a chain of pieces, not one ellipse whose
  // chi-square semi-axis (0.88 x its length) covers the free space around it.
  pieces_.clear();
  for (std::size_t i = 0; i < parts_.size(); ++i)
    splitByExtent(voxels_, parts_[i], dimensions, params_.max_segment_length, params_.segmentWidth(dimensions), pieces_);
  stats_.ms_split = timer.lap();

  // 7. One ellipsoid per piece, carrying its voxels (with their beam directions) for the tracker.
  const EllipsoidFitParams fit{params_.probability, params_.range_noise_sigma, params_.voxel_size,
                               params_.enclose_points};
  Eigen::Vector3f origin_f = sensor_origin.cast<float>();
  if (dimensions == 2) origin_f.z() = 0.0f;
  std::vector<ObstacleEllipsoid> obstacles;
  obstacles.reserve(pieces_.size());
  for (std::size_t i = 0; i < pieces_.size(); ++i) {
    ObstacleEllipsoid e;
    if (params_.fit_detections) {
      e = fitEllipsoid(voxels_, pieces_[i], sensor_origin, dimensions, fit);
    } else {
      e.dimensions = dimensions;
      e.probability = params_.probability;
      e.point_count = pieces_[i].size();
      for (int k : pieces_[i]) e.center += voxels_[static_cast<std::size_t>(k)].cast<double>();
      e.center /= static_cast<double>(pieces_[i].size());
    }
    e.support.reserve(pieces_[i].size());
    for (int k : pieces_[i]) {
      const Eigen::Vector3f& v = voxels_[static_cast<std::size_t>(k)];
      const Eigen::Vector3f ray = v - origin_f;
      const float range = ray.norm();
      e.support.push_back({v, range > 0.0f ? Eigen::Vector3f(ray / range) : Eigen::Vector3f::Zero()});
    }
    obstacles.push_back(std::move(e));
  }
  stats_.obstacles = obstacles.size();
  stats_.ms_fit = timer.lap();
  return obstacles;
}

// Clusters larger than structure_extent (box diagonal) leave clusters_ for structure_: one hill flank or
// one wall seen in a scan is one connected cluster, a discrete obstacle is a small one.
void ObstacleDetector::separateStructure() {
  obstacle_clusters_.clear();
  const double limit2 = params_.structure_extent * params_.structure_extent;
  for (std::size_t c = 0; c < clusters_.size(); ++c) {
    const auto cluster = clusters_[c];
    Eigen::Vector3f lo = voxels_[static_cast<std::size_t>(cluster[0])], hi = lo;
    for (int i : cluster) {
      lo = lo.cwiseMin(voxels_[static_cast<std::size_t>(i)]);
      hi = hi.cwiseMax(voxels_[static_cast<std::size_t>(i)]);
    }
    if (static_cast<double>((hi - lo).squaredNorm()) > limit2) {
      ++stats_.structure_clusters;
      for (int i : cluster) structure_.push_back(voxels_[static_cast<std::size_t>(i)]);
      continue;
    }
    obstacle_clusters_.indices.insert(obstacle_clusters_.indices.end(), cluster.begin(), cluster.end());
    obstacle_clusters_.offsets.push_back(static_cast<int>(obstacle_clusters_.indices.size()));
  }
  std::swap(clusters_, obstacle_clusters_);
}

// The paper counts an obstacle per continuous edge seen by the sensor: a cluster whose points,
// ordered by azimuth around the sensor, leave an angular gap that beams passed through is two
// obstacles. A gap between azimuth-neighbours i, j counts when
//   delta_azimuth > max(gap_min_width / min(r_i, r_j), gap_min_beams * beam_spacing)
// (r: horizontal range), i.e. it is wider than gap_min_width at that range and than a few beam
// steps, so the natural spacing of beams and voxels never splits a surface.
void ObstacleDetector::splitGaps(const Eigen::Vector3d& origin) {
  parts_.clear();
  const double two_pi = 2.0 * std::numbers::pi;
  const double min_angle = params_.gap_min_beams * params_.beam_spacing;
  std::vector<std::size_t> cuts;
  for (std::size_t c = 0; c < clusters_.size(); ++c) {
    const auto cluster = clusters_[c];
    bearings_.clear();
    for (int i : cluster) {
      const double dx = voxels_[i].x() - origin.x(), dy = voxels_[i].y() - origin.y();
      bearings_.push_back({static_cast<float>(std::atan2(dy, dx)),
                           static_cast<float>(std::max(1e-3, std::hypot(dx, dy))), i});
    }
    std::sort(bearings_.begin(), bearings_.end(),
              [](const Bearing& a, const Bearing& b) { return a.azimuth < b.azimuth; });
    const std::size_t n = bearings_.size();
    cuts.clear();  // a cut at k: a gap between bearings_[k - 1] and bearings_[k] (circularly)
    for (std::size_t k = 0; k < n; ++k) {
      const Bearing& prev = bearings_[(k + n - 1) % n];
      const Bearing& next = bearings_[k];
      double delta = next.azimuth - prev.azimuth;
      if (k == 0) delta += two_pi;
      const double range = std::min(prev.range, next.range);
      if (delta > std::max(params_.gap_min_width / range, min_angle)) cuts.push_back(k);
    }
    auto emit = [&](std::size_t begin, std::size_t count) {  // circular run of bearings_
      if (count < params_.min_cluster_size) return;
      for (std::size_t k = 0; k < count; ++k) parts_.indices.push_back(bearings_[(begin + k) % n].index);
      parts_.offsets.push_back(static_cast<int>(parts_.indices.size()));
    };
    if (cuts.size() <= 1) {  // one run around the circle (a single cut is the cluster's own edge)
      emit(cuts.empty() ? 0 : cuts[0], n);
      continue;
    }
    for (std::size_t g = 0; g < cuts.size(); ++g) {
      const std::size_t begin = cuts[g], end = cuts[(g + 1) % cuts.size()];
      emit(begin, (end + n - begin) % n);
    }
  }
}

}  // namespace ddsnav::perception
