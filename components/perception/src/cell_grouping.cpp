#include "cell_grouping.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <tuple>

namespace ddsnav::perception::detail {
namespace {

int bitWidth(std::uint64_t v) { return v == 0 ? 0 : static_cast<int>(std::bit_width(v)); }

}  // namespace

void CellGrouper::group(const std::vector<CellCoord>& cells, std::vector<std::uint32_t>& order,
                        std::vector<std::uint32_t>& starts) {
  const std::size_t n = cells.size();
  order.resize(n);
  starts.clear();
  if (n == 0) {
    starts.push_back(0);
    return;
  }
  CellCoord lo = cells[0], hi = cells[0];
  for (const auto& c : cells) {
    lo = {std::min(lo.x, c.x), std::min(lo.y, c.y), std::min(lo.z, c.z)};
    hi = {std::max(hi.x, c.x), std::max(hi.y, c.y), std::max(hi.z, c.z)};
  }
  const int bx = bitWidth(static_cast<std::uint64_t>(static_cast<std::int64_t>(hi.x) - lo.x));
  const int by = bitWidth(static_cast<std::uint64_t>(static_cast<std::int64_t>(hi.y) - lo.y));
  const int bz = bitWidth(static_cast<std::uint64_t>(static_cast<std::int64_t>(hi.z) - lo.z));
  const int bi = std::max(1, bitWidth(n - 1));
  const int key_bits = bx + by + bz;

  if (key_bits + bi > 64) {  // astronomically spread cells: comparison sort on the triples
    for (std::uint32_t i = 0; i < n; ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
      return std::tie(cells[a].x, cells[a].y, cells[a].z) < std::tie(cells[b].x, cells[b].y, cells[b].z);
    });
    for (std::size_t i = 0; i < n; ++i) {
      const auto& c = cells[order[i]];
      const auto& p = cells[order[i ? i - 1 : 0]];
      if (i == 0 || c.x != p.x || c.y != p.y || c.z != p.z) starts.push_back(static_cast<std::uint32_t>(i));
    }
    starts.push_back(static_cast<std::uint32_t>(n));
    return;
  }

  keys_.resize(n);
  scratch_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto& c = cells[i];
    const std::uint64_t key = ((static_cast<std::uint64_t>(c.x - lo.x) << by | static_cast<std::uint64_t>(c.y - lo.y))
                               << bz) | static_cast<std::uint64_t>(c.z - lo.z);
    keys_[i] = key << bi | i;
  }
  // LSD radix sort on the key bits only; the index bits below are already in order, and each
  // pass is stable, so points keep their input order inside a cell. Small inputs (the tracker
  // groups a few dozen leftover voxels at a time) sort the packed keys directly: every key is
  // unique (it holds the index), so the order is the same, without clearing and summing 2049
  // counters per pass (that was most of their cost).
  constexpr int kDigit = 11;
  constexpr std::size_t kSmall = 256;
  if (n <= kSmall) std::sort(keys_.begin(), keys_.end());
  for (int shift = bi; n > kSmall && shift < bi + key_bits; shift += kDigit) {
    std::array<std::uint32_t, (1u << kDigit) + 1> count{};
    for (std::uint64_t k : keys_) ++count[((k >> shift) & ((1u << kDigit) - 1)) + 1];
    for (std::size_t d = 1; d < count.size(); ++d) count[d] += count[d - 1];
    for (std::uint64_t k : keys_) scratch_[count[(k >> shift) & ((1u << kDigit) - 1)]++] = k;
    keys_.swap(scratch_);
  }
  const std::uint64_t index_mask = (std::uint64_t{1} << bi) - 1;
  std::uint64_t previous = 0;
  for (std::size_t i = 0; i < n; ++i) {
    order[i] = static_cast<std::uint32_t>(keys_[i] & index_mask);
    const std::uint64_t key = keys_[i] >> bi;
    if (i == 0 || key != previous) starts.push_back(static_cast<std::uint32_t>(i));
    previous = key;
  }
  starts.push_back(static_cast<std::uint32_t>(n));
}

}  // namespace ddsnav::perception::detail
