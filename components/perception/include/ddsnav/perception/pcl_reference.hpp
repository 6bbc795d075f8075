#pragma once
// The stock PCL pipeline, kept as the oracle for tests and the baseline for the benchmark:
//   pcl::VoxelGrid (leaf = voxel_size) -> z > ground_z threshold (3-D) ->
//   pcl::search::KdTree + pcl::EuclideanClusterExtraction (cluster_tolerance, min/max size) ->
//   pcl::computeMeanAndCovarianceMatrix + Eigen::SelfAdjointEigenSolver per cluster.
// The interface has no PCL types, so only one translation unit includes PCL headers.

#include <ddsnav/perception/obstacle_detector.hpp>

#include <Eigen/Core>

#include <memory>
#include <span>
#include <vector>

namespace ddsnav::perception {

struct PclClusterMoments {
  Eigen::Vector3d mean;
  Eigen::Matrix3d covariance;
  Eigen::Vector3d eigenvalues;  // ascending
  Eigen::Matrix3d eigenvectors;
};

class PclReferencePipeline {
 public:
  explicit PclReferencePipeline(const DetectorParams& params);
  ~PclReferencePipeline();

  // Copies the points into a pcl::PointCloud<PointXYZ> (not part of run()'s time).
  void setInput(std::span<const Eigen::Vector3f> points);
  // Runs the stock pipeline on the input set last; `dimensions` 3 removes ground.
  void run(int dimensions);

  // Results of the last run: voxel centroids after ground removal, clusters as indices into them
  // (PCL's order: largest first), and the per-cluster moments.
  const std::vector<Eigen::Vector3f>& voxels() const { return voxels_; }
  const std::vector<std::vector<int>>& clusters() const { return clusters_; }
  const std::vector<PclClusterMoments>& moments() const { return moments_; }
  std::size_t voxelCountBeforeGround() const { return voxels_before_ground_; }

 private:
  struct Impl;
  DetectorParams params_;
  std::unique_ptr<Impl> impl_;
  std::vector<Eigen::Vector3f> voxels_;
  std::vector<std::vector<int>> clusters_;
  std::vector<PclClusterMoments> moments_;
  std::size_t voxels_before_ground_ = 0;
};

}  // namespace ddsnav::perception
