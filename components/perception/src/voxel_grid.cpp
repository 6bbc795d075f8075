#include "ddsnav/perception/voxel_grid.hpp"

#include "cell_grouping.hpp"

#include <cmath>
#include <stdexcept>

namespace ddsnav::perception {

struct VoxelGrid::Buffers {
  std::vector<detail::CellCoord> cells;
  std::vector<std::uint32_t> source;  // input index of each entry of `cells`
  std::vector<std::uint32_t> order, starts;
  detail::CellGrouper grouper;
};

VoxelGrid::VoxelGrid(float leaf_size) : leaf_(leaf_size), buffers_(std::make_unique<Buffers>()) {
  if (!(leaf_size > 0.0f) || !std::isfinite(leaf_size))
    throw std::invalid_argument("VoxelGrid: leaf size must be finite and > 0");
}
VoxelGrid::~VoxelGrid() = default;
VoxelGrid::VoxelGrid(VoxelGrid&&) noexcept = default;
VoxelGrid& VoxelGrid::operator=(VoxelGrid&&) noexcept = default;

void VoxelGrid::filter(std::span<const Eigen::Vector3f> points, std::vector<Eigen::Vector3f>& centroids) {
  auto& b = *buffers_;
  const float inverse_leaf = 1.0f / leaf_;  // float, as pcl::VoxelGrid computes it
  constexpr float kLimit = 1073741824.0f;   // 2^30: keeps cell indices and their spans in int64/31 bits
  b.cells.clear();
  b.source.clear();
  b.cells.reserve(points.size());
  b.source.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    const float x = std::floor(p.x() * inverse_leaf), y = std::floor(p.y() * inverse_leaf),
                z = std::floor(p.z() * inverse_leaf);
    // Also rejects NaN and inf: every comparison with NaN is false.
    if (!(std::abs(x) < kLimit && std::abs(y) < kLimit && std::abs(z) < kLimit)) continue;
    b.cells.push_back({static_cast<std::int32_t>(x), static_cast<std::int32_t>(y), static_cast<std::int32_t>(z)});
    b.source.push_back(static_cast<std::uint32_t>(i));
  }
  b.grouper.group(b.cells, b.order, b.starts);

  const std::size_t voxels = b.starts.size() - 1;
  centroids.resize(voxels);
  for (std::size_t v = 0; v < voxels; ++v) {
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    for (std::uint32_t k = b.starts[v]; k < b.starts[v + 1]; ++k) sum += points[b.source[b.order[k]]];
    centroids[v] = sum / static_cast<float>(b.starts[v + 1] - b.starts[v]);
  }
}

}  // namespace ddsnav::perception
