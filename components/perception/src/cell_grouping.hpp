#pragma once
// Internal: groups points by integer cell coordinates (used by the voxel grid and the clusterer).

#include <cstdint>
#include <vector>

namespace ddsnav::perception::detail {

struct CellCoord {
  std::int32_t x, y, z;
};

// Orders indices 0..n-1 by cell (x, then y, then z), keeping the input order inside a cell.
// `order` receives the permutation, `starts` the offset of each distinct cell in `order`
// followed by n. LSD radix sort on (cell key, index) packed into 64 bits whenever the cells'
// bounding box allows it (any realistic cloud); std::sort on the triples otherwise.
class CellGrouper {
 public:
  void group(const std::vector<CellCoord>& cells, std::vector<std::uint32_t>& order,
             std::vector<std::uint32_t>& starts);

 private:
  std::vector<std::uint64_t> keys_, scratch_;
};

}  // namespace ddsnav::perception::detail
