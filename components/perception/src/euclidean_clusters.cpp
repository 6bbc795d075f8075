#include "ddsnav/perception/euclidean_clusters.hpp"

#include "cell_grouping.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace ddsnav::perception {
namespace {

// Open-addressing map from a column (cell x, y) to its range of cells, rebuilt per cloud.
class ColumnMap {
 public:
  struct Entry {
    std::uint64_t key;
    std::uint32_t begin, end;  // cells [begin, end) of this column, sorted by z
  };

  void reset(std::size_t columns) {
    std::size_t capacity = 16;
    shift_ = 60;
    while (capacity < 2 * columns) {
      capacity *= 2;
      --shift_;
    }
    mask_ = capacity - 1;
    table_.assign(capacity, Entry{kEmpty, 0, 0});
  }
  void insert(std::uint64_t key, std::uint32_t begin, std::uint32_t end) {
    std::size_t slot = hash(key);
    while (table_[slot].key != kEmpty) slot = (slot + 1) & mask_;
    table_[slot] = {key, begin, end};
  }
  const Entry* find(std::uint64_t key) const {
    std::size_t slot = hash(key);
    while (true) {
      const Entry& e = table_[slot];
      if (e.key == key) return &e;
      if (e.key == kEmpty) return nullptr;
      slot = (slot + 1) & mask_;
    }
  }
  static std::uint64_t columnKey(std::int32_t x, std::int32_t y) {
    return static_cast<std::uint64_t>(static_cast<std::uint32_t>(x)) << 32 | static_cast<std::uint32_t>(y);
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // (x, y) = (-1, -1) never maps here:
  // columnKey(-1, -1) equals kEmpty, so cell coordinates are offset to be >= 0 before use.
  // Fibonacci hashing: the top bits of the product mix both x (high word) and y (low word).
  std::size_t hash(std::uint64_t key) const { return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_); }
  std::vector<Entry> table_;
  std::size_t mask_ = 0;
  int shift_ = 60;
};

}  // namespace

struct EuclideanClusterer::Buffers {
  std::vector<detail::CellCoord> cells;
  std::vector<std::uint32_t> order, starts;
  detail::CellGrouper grouper;
  std::vector<Eigen::Vector3f> sorted;       // points in cell order
  std::vector<detail::CellCoord> cell_of;    // coordinate of each cell
  std::vector<Eigen::Vector3f> cell_lo, cell_hi;  // bounding box of each cell's points
  std::vector<std::uint32_t> parent;         // union-find over cells
  std::vector<std::uint32_t> point_cell;     // cell of each input point
  std::vector<int> root_cluster, cluster_size, cluster_first;
  std::vector<int> component_of_cell, kept, write;  // the clusters' assembly (kept: no allocation per call)
  ColumnMap columns;
};

EuclideanClusterer::EuclideanClusterer(const ClusterParams& params)
    : params_(params), buffers_(std::make_unique<Buffers>()) {
  if (!(params.tolerance > 0.0) || !std::isfinite(params.tolerance))
    throw std::invalid_argument("EuclideanClusterer: tolerance must be finite and > 0");
  if (params.min_size > params.max_size)
    throw std::invalid_argument("EuclideanClusterer: min_size must not exceed max_size");
}
EuclideanClusterer::~EuclideanClusterer() = default;
EuclideanClusterer::EuclideanClusterer(EuclideanClusterer&&) noexcept = default;
EuclideanClusterer& EuclideanClusterer::operator=(EuclideanClusterer&&) noexcept = default;

void EuclideanClusterer::extract(std::span<const Eigen::Vector3f> points, Clusters& clusters) {
  clusters.clear();
  auto& b = *buffers_;
  const std::size_t n = points.size();
  if (n == 0) return;

  // The neighbour relation of PCL's radius search: float squared distance < float(r * r).
  const float radius2 = static_cast<float>(params_.tolerance * params_.tolerance);
  // Cell edge: any two points of one cell are closer than the tolerance, with a margin far
  // above float rounding so the shortcut never disagrees with the exact test.
  const double cell = params_.tolerance / std::sqrt(3.0) * (1.0 - 1e-4);
  const double inverse_cell = 1.0 / cell;

  b.cells.resize(n);
  const double limit = 1073741824.0 * cell;  // keep cell coordinates (and their offsets) in 31 bits
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = points[i];
    if (!(std::abs(p.x()) < limit && std::abs(p.y()) < limit && std::abs(p.z()) < limit))
      throw std::invalid_argument("EuclideanClusterer: point " + std::to_string(i) +
                                  " is not finite or farther than " + std::to_string(limit) + " m from the origin");
    b.cells[i] = {static_cast<std::int32_t>(std::floor(p.x() * inverse_cell)),
                  static_cast<std::int32_t>(std::floor(p.y() * inverse_cell)),
                  static_cast<std::int32_t>(std::floor(p.z() * inverse_cell))};
  }
  b.grouper.group(b.cells, b.order, b.starts);
  const std::size_t cell_count = b.starts.size() - 1;

  b.sorted.resize(n);
  b.point_cell.resize(n);
  b.cell_of.resize(cell_count);
  b.cell_lo.resize(cell_count);
  b.cell_hi.resize(cell_count);
  for (std::size_t c = 0; c < cell_count; ++c) {
    b.cell_of[c] = b.cells[b.order[b.starts[c]]];
    Eigen::Vector3f lo = points[b.order[b.starts[c]]], hi = lo;
    for (std::uint32_t k = b.starts[c]; k < b.starts[c + 1]; ++k) {
      b.sorted[k] = points[b.order[k]];
      b.point_cell[b.order[k]] = static_cast<std::uint32_t>(c);
      lo = lo.cwiseMin(b.sorted[k]);
      hi = hi.cwiseMax(b.sorted[k]);
    }
    b.cell_lo[c] = lo;
    b.cell_hi[c] = hi;
  }

  // Columns (x, y) are contiguous runs of cells because cells are sorted by x, y, z.
  std::int32_t min_x = b.cell_of[0].x, min_y = b.cell_of[0].y;
  for (const auto& c : b.cell_of) {
    min_x = std::min(min_x, c.x);
    min_y = std::min(min_y, c.y);
  }
  auto columnKey = [&](std::int32_t x, std::int32_t y) {  // offset so coordinates are >= 0
    return ColumnMap::columnKey(x - min_x + 2, y - min_y + 2);
  };
  std::size_t column_count = 0;
  for (std::size_t c = 0; c < cell_count; ++c)
    column_count += c == 0 || b.cell_of[c].x != b.cell_of[c - 1].x || b.cell_of[c].y != b.cell_of[c - 1].y;
  b.columns.reset(column_count);
  for (std::size_t c = 0; c < cell_count;) {
    std::size_t e = c + 1;
    while (e < cell_count && b.cell_of[e].x == b.cell_of[c].x && b.cell_of[e].y == b.cell_of[c].y) ++e;
    b.columns.insert(columnKey(b.cell_of[c].x, b.cell_of[c].y), static_cast<std::uint32_t>(c),
                     static_cast<std::uint32_t>(e));
    c = e;
  }

  b.parent.resize(cell_count);
  std::iota(b.parent.begin(), b.parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (b.parent[x] != x) {
      b.parent[x] = b.parent[b.parent[x]];  // path halving
      x = b.parent[x];
    }
    return x;
  };
  auto anyPairClose = [&](std::uint32_t a, std::uint32_t c) {
    // Bounding boxes of the two cells' points farther apart than the tolerance: no pair can be
    // close. The test is conservative (a margin of 1e-4 of the tolerance), the exact check decides.
    float gap2 = 0.0f;
    for (int k = 0; k < 3; ++k) {
      const float gap = std::max({0.0f, b.cell_lo[a][k] - b.cell_hi[c][k], b.cell_lo[c][k] - b.cell_hi[a][k]});
      gap2 += gap * gap;
    }
    if (gap2 > radius2 * 1.001f) return false;
    for (std::uint32_t i = b.starts[a]; i < b.starts[a + 1]; ++i) {
      const Eigen::Vector3f& p = b.sorted[i];
      for (std::uint32_t j = b.starts[c]; j < b.starts[c + 1]; ++j) {
        const Eigen::Vector3f& q = b.sorted[j];
        const float dx = p.x() - q.x(), dy = p.y() - q.y(), dz = p.z() - q.z();
        float d2 = dx * dx;
        d2 += dy * dy;
        d2 += dz * dz;
        if (d2 < radius2) return true;
      }
    }
    return false;
  };

  // Join each cell with the occupied cells of the forward half of its 5x5x5 neighbourhood, one
  // column pair at a time: both columns are sorted by z, so the window [z - 2, z + 2] slides.
  for (std::uint32_t begin = 0; begin < cell_count;) {
    const std::int32_t x = b.cell_of[begin].x, y = b.cell_of[begin].y;
    std::uint32_t end = begin + 1;
    while (end < cell_count && b.cell_of[end].x == x && b.cell_of[end].y == y) ++end;
    for (int dx = 0; dx <= 2; ++dx) {
      for (int dy = (dx == 0 ? 0 : -2); dy <= 2; ++dy) {
        const bool same_column = dx == 0 && dy == 0;
        std::uint32_t other_begin = begin, other_end = end;
        if (!same_column) {
          const ColumnMap::Entry* column = b.columns.find(columnKey(x + dx, y + dy));
          if (!column) continue;
          other_begin = column->begin;
          other_end = column->end;
        }
        std::uint32_t lo = other_begin;
        for (std::uint32_t a = begin; a < end; ++a) {
          const std::int32_t z = b.cell_of[a].z;
          const std::int32_t z_lo = same_column ? z + 1 : z - 2;
          while (lo < other_end && b.cell_of[lo].z < z_lo) ++lo;
          for (std::uint32_t c = lo; c < other_end && b.cell_of[c].z <= z + 2; ++c) {
            const std::uint32_t ra = find(a), rc = find(c);
            if (ra == rc || !anyPairClose(a, c)) continue;
            b.parent[std::max(ra, rc)] = std::min(ra, rc);
          }
        }
      }
    }
    begin = end;
  }

  // Components -> clusters, filtered by size, points in ascending input order.
  b.root_cluster.assign(cell_count, -1);
  b.cluster_size.clear();
  b.cluster_first.clear();
  auto& component_of_cell = b.component_of_cell;
  component_of_cell.resize(cell_count);
  for (std::uint32_t c = 0; c < cell_count; ++c) {
    const std::uint32_t r = find(c);
    if (b.root_cluster[r] < 0) {
      b.root_cluster[r] = static_cast<int>(b.cluster_size.size());
      b.cluster_size.push_back(0);
      b.cluster_first.push_back(std::numeric_limits<int>::max());
    }
    const int k = b.root_cluster[r];
    component_of_cell[c] = k;
    b.cluster_size[k] += static_cast<int>(b.starts[c + 1] - b.starts[c]);
  }
  auto& kept = b.kept;
  kept.clear();
  for (int k = 0; k < static_cast<int>(b.cluster_size.size()); ++k) {
    const auto size = static_cast<std::size_t>(b.cluster_size[k]);
    if (size >= params_.min_size && size <= params_.max_size) kept.push_back(k);
  }
  for (std::size_t i = 0; i < n; ++i) {
    int& first = b.cluster_first[component_of_cell[b.point_cell[i]]];
    first = std::min(first, static_cast<int>(i));
  }
  std::sort(kept.begin(), kept.end(), [&](int x, int y) {
    if (b.cluster_size[x] != b.cluster_size[y]) return b.cluster_size[x] > b.cluster_size[y];
    return b.cluster_first[x] < b.cluster_first[y];
  });
  auto& write = b.write;  // next write position per component
  write.assign(b.cluster_size.size(), -1);
  clusters.offsets.resize(kept.size() + 1);
  clusters.offsets[0] = 0;
  for (std::size_t i = 0; i < kept.size(); ++i) {
    write[kept[i]] = clusters.offsets[i];
    clusters.offsets[i + 1] = clusters.offsets[i] + b.cluster_size[kept[i]];
  }
  clusters.indices.resize(clusters.offsets.back());
  for (std::size_t i = 0; i < n; ++i) {
    int& w = write[component_of_cell[b.point_cell[i]]];
    if (w >= 0) clusters.indices[w++] = static_cast<int>(i);
  }
}

}  // namespace ddsnav::perception
