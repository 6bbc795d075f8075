#pragma once
// Voxel-grid downsampling: one point (the centroid) per occupied cubic voxel.

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace ddsnav::perception {

// Same cell assignment as pcl::VoxelGrid (cell = floor(x * (1 / leaf)) in float), so the voxel
// set is identical; the cells are grouped with a radix sort on packed integer keys instead of
// PCL's std::sort of (index, point) pairs. Keeps its buffers between calls: reuse one instance.
class VoxelGrid {
 public:
  explicit VoxelGrid(float leaf_size);
  ~VoxelGrid();
  VoxelGrid(VoxelGrid&&) noexcept;
  VoxelGrid& operator=(VoxelGrid&&) noexcept;

  // Centroids of the occupied voxels, ordered by cell (x, y, z). Non-finite points and points
  // whose cell index would not fit 31 bits (|x| > ~2e8 leaves) are skipped.
  void filter(std::span<const Eigen::Vector3f> points, std::vector<Eigen::Vector3f>& centroids);

  float leafSize() const { return leaf_; }

 private:
  struct Buffers;
  float leaf_;
  std::unique_ptr<Buffers> buffers_;
};

}  // namespace ddsnav::perception
