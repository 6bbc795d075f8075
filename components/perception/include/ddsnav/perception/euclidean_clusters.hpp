#pragma once
// Euclidean cluster extraction with the semantics of pcl::EuclideanClusterExtraction.

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

namespace ddsnav::perception {

struct ClusterParams {
  double tolerance = 0.4;    // m; two points are neighbours when their distance is below it
  std::size_t min_size = 1;  // clusters with fewer points are dropped (not merged)
  std::size_t max_size = std::numeric_limits<std::size_t>::max();  // larger clusters are dropped
};

// Clusters as one flat index list: cluster i is indices[offsets[i] .. offsets[i + 1]).
struct Clusters {
  std::vector<int> indices;
  std::vector<int> offsets{0};

  std::size_t size() const { return offsets.size() - 1; }
  std::span<const int> operator[](std::size_t i) const {
    return {indices.data() + offsets[i], static_cast<std::size_t>(offsets[i + 1] - offsets[i])};
  }
  void clear() {
    indices.clear();
    offsets.assign(1, 0);
  }
};

// A cluster is a connected component of the graph whose edges join points with float squared
// distance < float(tolerance^2) — exactly the neighbour relation of PCL's k-d tree radius search,
// so the components (and, after the size filter, the clusters) are the same as PCL's.
//
// How: points are binned into cubic cells of edge tolerance / sqrt(3) (slightly less), so all points
// of a cell are within the tolerance of each other and form one set of a union-find over cells.
// A cell is then joined with each occupied cell of its 5x5x5 neighbourhood (the cells that can hold a
// point within the tolerance) as soon as one exact point pair is closer than the tolerance, skipping
// pairs already in the same set. Cells are grouped by a radix sort; neighbour columns are found in a
// hash map. Keeps its buffers between calls.
class EuclideanClusterer {
 public:
  explicit EuclideanClusterer(const ClusterParams& params = {});
  ~EuclideanClusterer();
  EuclideanClusterer(EuclideanClusterer&&) noexcept;
  EuclideanClusterer& operator=(EuclideanClusterer&&) noexcept;

  // Clusters sorted by size, largest first (ties: smallest first index); indices ascending inside.
  // Points must be finite.
  void extract(std::span<const Eigen::Vector3f> points, Clusters& clusters);

  const ClusterParams& params() const { return params_; }

 private:
  struct Buffers;
  ClusterParams params_;
  std::unique_ptr<Buffers> buffers_;
};

}  // namespace ddsnav::perception
