#pragma once
// Point cloud -> obstacle ellipses / ellipsoids (the GART paper's obstacle modelling with
// uncertainty). No DDS, no PCL in this interface.
//
//   ObstacleDetector detector(DetectorParams{});                 // defaults: 0.1 m voxels, p = 0.99
//   std::vector<ObstacleEllipsoid> obstacles = detector.detect(cloud.points, cloud.origin);
//
// Pipeline per cloud (see docs/perception.md):
//   1. drop non-finite points and points farther than max_range from the sensor
//   2. voxel-grid downsample (centroid per voxel_size cube)
//   3. 3-D only: drop ground, i.e. voxel centroids with z <= ground_z
//   4. Euclidean clustering (PCL EuclideanClusterExtraction semantics, cluster_tolerance,
//      min/max_cluster_size); with structure_extent > 0, a cluster whose bounding box diagonal is
//      longer than that is static structure (terrain, walls — the map's job, not an obstacle):
//      its voxels go to structure() instead of on to the next steps
//   5. split clusters whose points are not contiguous as seen from the sensor (an azimuth gap the
//      beams passed through makes two obstacles, as in the paper's obstacle counting)
//   6. cut a part longer than max_segment_length (or thicker than max_segment_width) into
//      consecutive pieces (splitByExtent), so a wall becomes a chain of tight ellipses instead of
//      one that spans free space
//   7. fit the probability-p ellipsoid to each piece (fitEllipsoid); each carries its voxels as
//      `support` for the tracker (fit_detections = false: the voxels only, for a tracker that refits)

#include <ddsnav/perception/euclidean_clusters.hpp>
#include <ddsnav/perception/obstacle.hpp>
#include <ddsnav/perception/voxel_grid.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <numbers>
#include <span>
#include <vector>

namespace ddsnav::perception {

struct DetectorParams {
  double voxel_size = 0.1;             // m
  double max_range = 200.0;            // m from the sensor; farther points are dropped as invalid
  bool remove_ground = true;           // 3-D only
  double ground_z = 0.15;              // m; voxel centroids at or below it are ground
  double cluster_tolerance = 0.4;      // m
  std::size_t min_cluster_size = 3;    // voxels
  std::size_t max_cluster_size = 1000000;
  bool split_gaps = true;              // step 5
  double gap_min_width = 0.3;          // m; a see-through gap narrower than this is not a gap
  double beam_spacing = 2.0 * std::numbers::pi / 1024.0;  // rad, the sensor's azimuth step
  double gap_min_beams = 3.0;          // a gap must also span this many beam steps
  double max_segment_length = 1.5;     // m; longer parts are cut into pieces (step 6); 0: never cut
  double max_segment_width = 0.25;     // m; thicker pieces (an L, a curved arc) are halved (step 6), 2-D
  double max_segment_width_3d = 0.4;   // m; the same in 3-D (thicker surfaces: more pieces would be more tracks)
  double segmentWidth(int dimensions) const { return dimensions == 3 ? max_segment_width_3d : max_segment_width; }
  double probability = 0.99;           // p of the ellipsoids
  double range_noise_sigma = 0.02;     // m, the sensor's range noise
  bool enclose_points = true;          // see EllipsoidFitParams::enclose_points
  std::size_t max_points = 20000000;   // larger clouds are rejected (std::invalid_argument)
  double structure_extent = 0.0;       // m; clusters with a longer box diagonal are structure (step 4); 0: none
  // Step 7 on or off. Off, a detection carries its voxels (`support`), `dimensions`, `probability`,
  // `point_count` and the voxels' mean as `center`, but no ellipse (zero covariance and semi-axes):
  // all ObstacleTracker reads, which refits its tracks from the voxels anyway — the perception
  // component publishes tracks only, so it saves the fit (~20 % of detection time on a 16-beam lidar).
  bool fit_detections = true;

  // Throws std::invalid_argument naming the first bad parameter.
  void validate() const;
};

// What the last detect() saw, for logs, tests and benchmarks.
struct DetectionStats {
  std::size_t input_points = 0;
  std::size_t dropped_invalid = 0;   // non-finite or beyond max_range
  std::size_t voxels = 0;            // after downsampling
  std::size_t ground_voxels = 0;
  std::size_t clusters = 0;          // Euclidean clusters (before gap splitting)
  std::size_t clustered_points = 0;  // voxels in those clusters
  std::size_t structure_clusters = 0;  // clusters taken as structure (not obstacles)
  std::size_t parts = 0;             // after the gap split (before the length cut)
  std::size_t obstacles = 0;         // ellipsoids reported (pieces)
  double ms_filter = 0, ms_voxel = 0, ms_cluster = 0, ms_split = 0, ms_fit = 0;
};

class ObstacleDetector {
 public:
  explicit ObstacleDetector(const DetectorParams& params = {});

  // `dimensions`: 2 (ellipses, z ignored), 3 (ellipsoids), or 0 to infer it (2 when every finite
  // point has z == 0). Throws std::invalid_argument for a non-finite origin or a cloud larger
  // than max_points; bad points are dropped and counted.
  std::vector<ObstacleEllipsoid> detect(std::span<const Eigen::Vector3f> points,
                                        const Eigen::Vector3d& sensor_origin, int dimensions = 0);

  const DetectionStats& stats() const { return stats_; }
  // Intermediate results of the last detect(): the non-ground voxel centroids and the Euclidean
  // clusters over them (before gap splitting) — the stage the PCL pipeline is compared on.
  const std::vector<Eigen::Vector3f>& voxels() const { return voxels_; }
  const Clusters& clusters() const { return clusters_; }
  // The voxels of the last detect()'s structure clusters (step 4), for ObstacleTracker::markStructure.
  const std::vector<Eigen::Vector3f>& structure() const { return structure_; }
  const DetectorParams& params() const { return params_; }

 private:
  void splitGaps(const Eigen::Vector3d& origin);
  void separateStructure();

  DetectorParams params_;
  VoxelGrid voxel_grid_;
  EuclideanClusterer clusterer_;
  std::vector<Eigen::Vector3f> finite_, voxels_, structure_;
  Clusters clusters_, parts_, pieces_, obstacle_clusters_;
  DetectionStats stats_;
  struct Bearing {
    float azimuth, range;
    int index;
  };
  std::vector<Bearing> bearings_;
};

}  // namespace ddsnav::perception
