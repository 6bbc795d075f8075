#include "ddsnav/mapper/occupancy_mapper.hpp"

#include "fast_insert.hpp"

#include <octomap/OcTree.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace ddsnav::mapper {
namespace {

bool isProbability(double p) { return std::isfinite(p) && p > 0.0 && p < 1.0; }

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The farthest a clipped ray may reach, in voxels: OctoMap's KeyRay holds at most 100000 keys, and a ray
// of length L crosses at most sqrt(3) * L / resolution + 3 of them.
constexpr double kMaxRangeVoxels = 30000.0;

// One walk of the tree that writes the map as OctoMap's binary stream of its maximum-likelihood tree — what
// AbstractOccupancyOcTree::writeBinary writes after toMaxLikelihood() and prune(), without changing the live tree:
// eight leaves of one class (all free or all occupied) are written as their parent, a leaf. Per inner node two bytes,
// two bits per child (00 unknown, 01 occupied leaf, 10 free leaf, 11 inner, first bit lowest), children 1-4 then 5-8,
// then the inner children depth first. On the way it counts the nodes and leaves and bounds the leaves' keys.
// OctoMap's writeBinaryNode (a std::bitset and two ostream writes per node), calcMinMax (a leaf iterator) and
// getNumLeafNodes were three walks and 64 % of the mapper's CPU on gart_terrain_3d at 5 exports a second, and the
// unpruned stream was 2.7 MB that the tracker and the planner read back at that rate.
//
// The walk of a region (detail::kChangeRegionDepth) is kept with its bytes, counts and bounds; the next export copies
// it instead of walking again unless a voxel in the region changed class in between (the stream depends on the
// classes alone). In flight most scans only look again at what the map already holds: on gart_terrain_3d the
// full walk was 46 % of the mapper's CPU (perf, 2026-12-06); with the kept walks an export took 35 ms against the
// full walk's 104 ms on the same maps, both run on each of 158 exports of a real-time mission, bytes equal in all.
struct RegionExport {
  unsigned code = 0;  // as walk() returns it
  std::vector<std::uint8_t> bytes;
  std::size_t nodes = 0, leaves = 0;
  std::size_t occupied_leaves = 0;
  std::array<int, 3> lo{}, hi{};
};
using RegionExports = std::unordered_map<std::uint64_t, RegionExport>;

class MaxLikelihoodExport {
 public:
  // `regions` (may be null): the regions' walks kept from earlier exports, looked up and filled in.
  explicit MaxLikelihoodExport(const octomap::OcTree& tree, RegionExports* regions = nullptr)
      : tree_(tree), regions_(regions) {}

  // Appends the subtree of an inner node; returns its code as its parent writes it: 3 (inner), or 1 / 2 when
  // its eight children are leaves of one class (then nothing of it stays in `out`). `root`: never collapsed
  // (OctoMap's prune stops below the root).
  unsigned walk(const octomap::OcTreeNode* node, const std::array<int, 3>& key_lo, int size, bool root = false) {
    if (regions_ != nullptr && size == kRegionKeys) return walkRegion(node, key_lo, size);
    return walkNode(node, key_lo, size, root);
  }

  void leaf(const std::array<int, 3>& key_lo, int size) {
    ++leaves;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], key_lo[a]);
      hi[a] = std::max(hi[a], key_lo[a] + size);
    }
  }

  static std::array<int, 3> childKey(const std::array<int, 3>& key_lo, unsigned i, int half) {
    return {key_lo[0] + ((i & 1u) ? half : 0), key_lo[1] + ((i & 2u) ? half : 0), key_lo[2] + ((i & 4u) ? half : 0)};
  }

  static constexpr std::array<int, 3> kNoLo{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(), std::numeric_limits<int>::max()};
  static constexpr std::array<int, 3> kNoHi{std::numeric_limits<int>::min(), std::numeric_limits<int>::min(), std::numeric_limits<int>::min()};
  std::vector<std::uint8_t> out;
  std::size_t nodes = 0, leaves = 0;
  std::size_t occupied_leaves = 0;  // of them
  std::array<int, 3> lo = kNoLo;
  std::array<int, 3> hi = kNoHi;

 private:
  static constexpr int kRegionKeys = 1 << (16 - detail::kChangeRegionDepth);

  // A region's node: its kept walk, or a walk kept for the next export. The walk's counts and bounds are
  // gathered apart from the rest, then added.
  unsigned walkRegion(const octomap::OcTreeNode* node, const std::array<int, 3>& key_lo, int size) {
    const octomap::OcTreeKey key(static_cast<octomap::key_type>(key_lo[0]), static_cast<octomap::key_type>(key_lo[1]),
                                 static_cast<octomap::key_type>(key_lo[2]));
    const std::uint64_t region = detail::changeRegionOf(detail::mortonCode(key));
    auto kept = regions_->find(region);
    if (kept == regions_->end()) {
      const std::size_t at = out.size();
      const std::size_t nodes_before = std::exchange(nodes, 0), leaves_before = std::exchange(leaves, 0);
      const std::size_t occupied_before = std::exchange(occupied_leaves, 0);
      const std::array<int, 3> lo_before = std::exchange(lo, kNoLo), hi_before = std::exchange(hi, kNoHi);
      RegionExport walked;
      walked.code = walkNode(node, key_lo, size, false);
      walked.bytes.assign(out.begin() + static_cast<std::ptrdiff_t>(at), out.end());
      walked.nodes = nodes;
      walked.leaves = leaves;
      walked.occupied_leaves = occupied_leaves + (walked.code == 2u ? 1 : 0);  // 2: the region is one occupied leaf
      walked.lo = lo;
      walked.hi = hi;
      nodes = nodes_before;
      leaves = leaves_before;
      occupied_leaves = occupied_before;
      lo = lo_before;
      hi = hi_before;
      out.resize(at);
      kept = regions_->emplace(region, std::move(walked)).first;
    }
    const RegionExport& r = kept->second;
    out.insert(out.end(), r.bytes.begin(), r.bytes.end());
    nodes += r.nodes;
    leaves += r.leaves;
    occupied_leaves += r.occupied_leaves;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], r.lo[a]);
      hi[a] = std::max(hi[a], r.hi[a]);
    }
    return r.code;
  }

  unsigned walkNode(const octomap::OcTreeNode* node, const std::array<int, 3>& key_lo, int size, bool root) {
    const std::size_t at = out.size();
    out.push_back(0);
    out.push_back(0);
    const int half = size / 2;
    unsigned codes[8];
    int present = 0;
    for (unsigned i = 0; i < 8; ++i) {
      codes[i] = 0;
      if (!tree_.nodeChildExists(node, i)) continue;
      ++present;
      const octomap::OcTreeNode* child = tree_.getNodeChild(node, i);
      codes[i] = tree_.nodeHasChildren(child) ? walk(child, childKey(key_lo, i, half), half) : tree_.isNodeOccupied(child) ? 2u : 1u;
    }
    if (!root && present == 8 && codes[0] != 3u && std::all_of(codes + 1, codes + 8, [&](unsigned c) { return c == codes[0]; })) {
      out.resize(at);
      return codes[0];
    }
    std::uint8_t bits[2] = {0, 0};
    for (unsigned i = 0; i < 8; ++i) {
      bits[i / 4] |= static_cast<std::uint8_t>(codes[i] << (2 * (i % 4)));
      if (codes[i] == 1u || codes[i] == 2u) leaf(childKey(key_lo, i, half), half);
      if (codes[i] == 2u) ++occupied_leaves;
    }
    out[at] = bits[0];
    out[at + 1] = bits[1];
    nodes += static_cast<std::size_t>(present);
    return 3u;
  }

  const octomap::OcTree& tree_;
  RegionExports* regions_;
};

}  // namespace

// The header AbstractOccupancyOcTree::writeBinaryConst writes. OctoMap's own call is not used because Debian's
// build prints "Writing N nodes..." / " done." on stderr for every call, i.e. for every map the mapper publishes.
void writeOctreeHeader(const octomap::OcTree& tree, std::size_t node_count, std::ostream& out) {
  out << "# Octomap OcTree binary file\n# (feel free to add / change comments, but leave the first line as it is!)\n#\n"
      << "id " << tree.getTreeType() << '\n'
      << "size " << node_count << '\n'
      << "res " << tree.getResolution() << '\n'
      << "data\n";
}

void writeOctreeBinary(const octomap::OcTree& tree, std::ostream& out) {
  writeOctreeHeader(tree, tree.size(), out);
  if (tree.getRoot() != nullptr) tree.writeBinaryNode(out, tree.getRoot());
}

std::string validateConfig(const MapperConfig& c) {
  if (!std::isfinite(c.resolution) || c.resolution < 0.001 || c.resolution > 100.0)
    return "mapper parameter 'resolution' must be a finite number in [0.001, 100] m, got " + fmt(c.resolution);
  if (c.dimensions != 2 && c.dimensions != 3)
    return "mapper parameter 'dimensions' must be 2 or 3, got " + std::to_string(c.dimensions);
  if (!std::isfinite(c.slab_z)) return "mapper parameter 'slab_z' must be finite, got " + fmt(c.slab_z);
  if (!(c.max_surface_fill_m >= 0.0 && c.max_surface_fill_m <= 1e4))
    return "mapper parameter 'max_surface_fill_m' must be in [0, 10000] m (0: the scan's max_range / 8), got " + fmt(c.max_surface_fill_m);
  if (!(c.max_clear_gap_rad > 0.0 && c.max_clear_gap_rad <= std::numbers::pi))
    return "mapper parameter 'max_clear_gap_deg' must be in (0, 180] degrees, got " + fmt(c.max_clear_gap_rad * 180.0 / std::numbers::pi);
  if (!isProbability(c.prob_hit) || c.prob_hit <= 0.5)
    return "mapper parameter 'prob_hit' must be in (0.5, 1), got " + fmt(c.prob_hit);
  if (!isProbability(c.prob_miss) || c.prob_miss >= 0.5)
    return "mapper parameter 'prob_miss' must be in (0, 0.5), got " + fmt(c.prob_miss);
  if (!isProbability(c.occupancy_threshold))
    return "mapper parameter 'occupancy_threshold' must be in (0, 1), got " + fmt(c.occupancy_threshold);
  if (!isProbability(c.clamping_min) || !isProbability(c.clamping_max) || !(c.clamping_min < c.clamping_max))
    return "mapper parameters 'clamping_min' < 'clamping_max' must both be in (0, 1), got " + fmt(c.clamping_min) +
           " and " + fmt(c.clamping_max);
  if (c.threads < 1 || c.threads > 64)
    return "mapper parameter 'threads' must be in [1, 64], got " + std::to_string(c.threads);
  if (c.max_points < 1) return "mapper parameter 'max_points' must be at least 1";
  if (!(c.free_discovery_near_range_m >= 0.0 && c.free_discovery_near_range_m <= 1e5))
    return "mapper parameter 'free_discovery_near_range_m' must be in [0, 100000] m, got " + fmt(c.free_discovery_near_range_m);
  if (c.free_discovery_delay_exports < 0 || c.free_discovery_delay_exports > 1000)
    return "mapper parameter 'free_discovery_delay_exports' must be in [0, 1000] exports, got " + std::to_string(c.free_discovery_delay_exports);
  return {};
}

void applySensorModel(octomap::OcTree& tree, const MapperConfig& c) {
  tree.setProbHit(c.prob_hit);
  tree.setProbMiss(c.prob_miss);
  tree.setOccupancyThres(c.occupancy_threshold);
  tree.setClampingThresMin(c.clamping_min);
  tree.setClampingThresMax(c.clamping_max);
}

namespace {

// A return as seen from the scan's origin: its bearing in its ring (a planar scan has one) and its range.
struct Beam {
  double bearing = 0.0;  // rad
  double range = 0.0;    // m
  // A return the sensor could not measure (a non-finite point) lies next to this one in the cloud's order.
  bool beside_invalid = false;
  bool operator<(const Beam& o) const { return bearing < o.bearing || (bearing == o.bearing && range < o.range); }
};

// The bearing from return i to the next (sorted by bearing, the last one's next is the first, a turn later).
double bearingGapAfter(const std::vector<Beam>& beams, std::size_t i) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  return i + 1 < beams.size() ? beams[i + 1].bearing - beams[i].bearing : beams.front().bearing + kTwoPi - beams.back().bearing;
}
}  // namespace

struct OccupancyMapper::Impl {
  explicit Impl(double resolution) : tree(resolution) {}
  octomap::OcTree tree;
  detail::FastInserter inserter;
  std::vector<octomap::point3d> cleaned;
  std::vector<bool> beside_invalid;  // per cleaned point: a non-finite point next to it in the cloud
  std::vector<Beam> beams;           // clear_beam_gaps' scratch space
  std::vector<double> gaps;
  std::vector<std::pair<double, Beam>> by_elevation;  // 3-D clear_beam_gaps' scratch space: (elevation, beam)
  std::vector<octomap::point3d> gap_rays;  // the ends of clear_beam_gaps' rays
  std::vector<octomap::point3d> surface_fill;  // fill_surfaces_between_returns' points
  RegionExports region_exports;  // exportMap's kept walks (MaxLikelihoodExport)
  // Regions whose kept walk lacks free space observed since (MapperConfig::free_discovery_delay_exports), with the
  // number of the export that first left it out.
  std::unordered_map<std::uint64_t, std::uint64_t> delayed_regions;
  std::uint64_t exports = 0;
  std::size_t regionExportBytes() const {
    std::size_t bytes = region_exports.size() * (sizeof(RegionExports::value_type) + 2 * sizeof(void*)) +
                        delayed_regions.size() * (sizeof(decltype(delayed_regions)::value_type) + 2 * sizeof(void*));
    for (const auto& [region, walked] : region_exports) bytes += walked.bytes.capacity();
    return bytes;
  }
};

namespace {
// `beams` sorted by bearing; returns the scanner's angular step, the 10th percentile of the gaps between distinct
// neighbouring bearings (most neighbours are one step apart; gaps where beams returned nothing are several), or 0
// when there are too few returns to tell. `gaps` is scratch space.
double sortAndStep(std::vector<Beam>& beams, std::vector<double>& gaps) {
  if (beams.size() < 8) return 0.0;
  std::sort(beams.begin(), beams.end());
  gaps.clear();
  for (std::size_t i = 0; i < beams.size(); ++i)
    if (const double g = bearingGapAfter(beams, i); g > 1e-6) gaps.push_back(g);
  if (gaps.size() < 8) return 0.0;
  const std::size_t tenth = gaps.size() / 10;
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(tenth), gaps.end());
  return gaps[tenth] > 1e-6 ? gaps[tenth] : 0.0;
}

// A planar scan's returns sorted by bearing, into `beams` (`beside_invalid` per point, as the mapper's Impl keeps it);
// returns the scanner's angular step (sortAndStep).
double sortedBeams(const std::vector<octomap::point3d>& points, const std::vector<bool>& beside_invalid, const octomap::point3d& origin,
                   std::vector<Beam>& beams, std::vector<double>& gaps) {
  beams.clear();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double dx = double(points[i].x()) - origin.x(), dy = double(points[i].y()) - origin.y();
    if (dx * dx + dy * dy > 1e-12) beams.push_back({std::atan2(dy, dx), std::sqrt(dx * dx + dy * dy), beside_invalid[i]});
  }
  return sortAndStep(beams, gaps);
}

// MapperConfig::clear_beam_gaps: the rays through the gaps of one ring's bearings (`beams` and `step` from
// sortAndStep; `elevation` the ring's, 0 for a planar scan), as their ends (cleared up to them); returns how many, at
// most `limit`.
std::size_t addBeamGapRays(const std::vector<Beam>& beams, double step, double elevation, const octomap::point3d& origin,
                           double max_range, double max_gap, std::size_t limit, std::vector<octomap::point3d>& ray_ends) {
  // A ray is cleared to twice the farther of the returns bounding its gap, as far as max_range (far enough to see
  // past what the neighbours hit, without a 66 m ray for every gap by a near wall).
  if (!(step > 0.0)) return 0;
  const double across = std::cos(elevation), up = std::sin(elevation);
  std::size_t added = 0;
  for (std::size_t i = 0; i < beams.size() && added < limit; ++i) {
    const double g = bearingGapAfter(beams, i);
    // Three beams missing at least: one or two are returns the sensor could not measure (NaN, dropped above), and a
    // ray through their gap crosses the surface their neighbours hit (stunnel_small_0.5, 1.4 % of the returns
    // invalid: the corridor's walls were cleared away beam by beam and the mission failed).
    if (!(g > 3.5 * step) || g > max_gap) continue;
    // Nor a gap beside a return the sensor could not measure: it is one of the gap's bearings, and the surface its
    // neighbour hit may lie across it. Seen at a grazing angle that surface runs along the gap's first ray for metres:
    // on bugtrap_0.4 a dropped return at 1.5 degrees, next to the open bearings down the neck, made a gap ray there that
    // cleared 7.5 m of the inside of the neck's wall beyond its last hit (cells behind the face observed free, found
    // in a mission's map), and no hidden continuation or unknown margin could close the wall there again.
    const Beam& next = beams[(i + 1) % beams.size()];
    if (beams[i].beside_invalid || next.beside_invalid) continue;
    const double reach = std::min(max_range, 2.0 * std::max(beams[i].range, next.range));
    const auto rays = static_cast<std::size_t>(std::floor(g / step - 0.5));
    for (std::size_t r = 1; r <= rays && added < limit; ++r, ++added) {
      const double a = beams[i].bearing + g * double(r) / double(rays + 1);
      ray_ends.emplace_back(static_cast<float>(origin.x() + reach * across * std::cos(a)),
                            static_cast<float>(origin.y() + reach * across * std::sin(a)), static_cast<float>(origin.z() + reach * up));
    }
  }
  return added;
}

// MapperConfig::clear_beam_gaps in 3-D: a spinning lidar's returns grouped by ring (their elevation seen from the
// origin: a ring's beams share one, up to the float rounding of the points), and each ring's gaps cleared as a
// planar scan's (addBeamGapRays, `limit` rays in all). A cloud that is not made of rings (more than kMaxRings
// distinct elevations) gets none: a gap then means nothing.
std::size_t addRingGapRays(const std::vector<octomap::point3d>& points, const std::vector<bool>& beside_invalid,
                           const octomap::point3d& origin, double max_range, double max_gap, std::size_t limit,
                           std::vector<std::pair<double, Beam>>& by_elevation, std::vector<Beam>& beams,
                           std::vector<double>& gaps, std::vector<octomap::point3d>& ray_ends) {
  constexpr std::size_t kMaxRings = 256;
  // Two beams of one ring differ in elevation by the points' float rounding (1e-7 of their coordinates, a few
  // micro-radians at the ranges mapped); rings of real lidars are a tenth of a degree apart or more.
  constexpr double kSameRing = 2e-4;  // rad
  by_elevation.clear();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double dx = double(points[i].x()) - origin.x(), dy = double(points[i].y()) - origin.y(), dz = double(points[i].z()) - origin.z();
    const double horizontal = std::sqrt(dx * dx + dy * dy);
    if (horizontal > 1e-6)
      by_elevation.emplace_back(std::atan2(dz, horizontal), Beam{std::atan2(dy, dx), std::sqrt(dx * dx + dy * dy + dz * dz), beside_invalid[i]});
  }
  std::sort(by_elevation.begin(), by_elevation.end());
  std::size_t rings = 0;
  for (std::size_t i = 0; i < by_elevation.size(); ++i)
    if (i == 0 || by_elevation[i].first - by_elevation[i - 1].first > kSameRing) ++rings;
  if (rings > kMaxRings) return 0;
  std::size_t added = 0;
  for (std::size_t first = 0; first < by_elevation.size();) {
    std::size_t last = first + 1;
    while (last < by_elevation.size() && by_elevation[last].first - by_elevation[last - 1].first <= kSameRing) ++last;
    beams.clear();
    double elevation_sum = 0.0;
    for (std::size_t k = first; k < last; ++k) {
      beams.push_back(by_elevation[k].second);
      elevation_sum += by_elevation[k].first;
    }
    const double step = sortAndStep(beams, gaps);
    added += addBeamGapRays(beams, step, elevation_sum / double(last - first), origin, max_range, max_gap, limit - added, ray_ends);
    first = last;
  }
  return added;
}

// MapperConfig::fill_surfaces_between_returns: points every half voxel on the segments between neighbouring returns
// (`beams` and `step` from sortedBeams) that lie on one straight surface — both on the line of their own neighbours
// (or with no return beyond them to test), within `tolerance` along the beam, one at least on it — up to max_length
// long; returns how many (at most `limit`).
std::size_t addSurfaceFill(const std::vector<Beam>& beams, double step, const octomap::point3d& origin,
                           double resolution, double tolerance, double max_length, std::size_t limit,
                           std::vector<octomap::point3d>& out) {
  out.clear();
  const std::size_t n = beams.size();
  if (n < 3 || !(step > 0.0)) return 0;
  const auto at = [&](std::size_t i) {
    const Beam& b = beams[i % n];
    return std::pair{origin.x() + b.range * std::cos(b.bearing), origin.y() + b.range * std::sin(b.bearing)};
  };
  // Neighbours: one step apart (a gap of missing beams may hide anything).
  const auto neighbours = [&](std::size_t i) { return bearingGapAfter(beams, i % n) < 1.5 * step; };
  // Return i on the segment between its neighbours' returns (i - 1, i + 1): its beam meets that segment within
  // `tolerance` of its measured range. Measured along the beam, a surface seen at a grazing angle is told from a
  // return just behind it (through an opening at its end, a few centimetres beyond its line: stunnel_small_0.5's
  // turn) as clearly as from one just in front, where a distance to the line would take both for the surface.
  const auto onLine = [&](std::size_t i) {
    if (!neighbours(i + n - 1) || !neighbours(i)) return false;
    const auto [ax, ay] = at(i + n - 1);
    const auto [cx, cy] = at(i + 1);
    const Beam& beam = beams[i % n];
    const double ux = std::cos(beam.bearing), uy = std::sin(beam.bearing);  // the beam's direction
    const double vx = cx - ax, vy = cy - ay;                      // the segment
    const double across = ux * vy - uy * vx;
    if (!(std::abs(across) > 1e-9 * std::hypot(vx, vy))) return false;  // the beam runs along the segment
    const double wx = ax - origin.x(), wy = ay - origin.y();
    const double meets = (wx * vy - wy * vx) / across;  // range at which the beam meets the segment's line
    const double t = (wx * uy - wy * ux) / across;      // where on the segment (0: a, 1: c)
    return t > 0.0 && t < 1.0 && std::abs(meets - beam.range) <= tolerance;
  };
  std::vector<bool> on_line(n);
  for (std::size_t i = 0; i < n; ++i) on_line[i] = onLine(i);
  // Both ends of the segment must be on the surface: each on the line of its neighbours, or with no return beyond
  // it to test (a missing beam; the scan's edge). One end alone is not enough: a beam that passes a wall's convex
  // end at a grazing angle runs on nearly along the wall's line and may hit the surface behind it on that line (a
  // corridor turning off past the end: stunnel_v1_0.5's connector, its wall's last two hits and the ceiling 2 m
  // beyond the corner within 2 mm of one line). That return's own neighbours lie on the surface it really hit,
  // not on the wall's line, so the segment to it is not filled and the turn stays open.
  const auto surfaceEnd = [&](std::size_t end, std::size_t beyond_gap_after) {
    return on_line[end % n] || !neighbours(beyond_gap_after);
  };
  for (std::size_t i = 0; i < n && out.size() < limit; ++i) {
    if (!neighbours(i) || !(on_line[i] || on_line[(i + 1) % n])) continue;
    if (!surfaceEnd(i, i + n - 1) || !surfaceEnd(i + 1, i + 1)) continue;
    const auto [ax, ay] = at(i);
    const auto [bx, by] = at(i + 1);
    const double length = std::hypot(bx - ax, by - ay);
    if (!(length > 0.5 * resolution) || length > max_length) continue;  // one voxel already, or too far apart
    const auto points = static_cast<std::size_t>(std::floor(2.0 * length / resolution));
    for (std::size_t k = 1; k < points && out.size() < limit; ++k) {
      const double t = double(k) / double(points);
      out.emplace_back(static_cast<float>(ax + t * (bx - ax)), static_cast<float>(ay + t * (by - ay)), origin.z());
    }
  }
  return out.size();
}
}  // namespace

OccupancyMapper::OccupancyMapper(const MapperConfig& config) : config_(config) {
  if (std::string error = validateConfig(config); !error.empty()) throw std::invalid_argument(error);
  impl_ = std::make_unique<Impl>(config.resolution);
  applySensorModel(impl_->tree, config);
}

OccupancyMapper::~OccupancyMapper() = default;

InsertResult OccupancyMapper::insert(const Scan& scan) {
  const auto started = std::chrono::steady_clock::now();
  InsertResult result;
  octomap::OcTree& tree = impl_->tree;
  const double max_range_limit = kMaxRangeVoxels * config_.resolution;

  // Checked once here, at the boundary; the insertion below trusts its input.
  if (!(scan.max_range > 0.0) || !(scan.max_range <= max_range_limit)) {
    result.message = "scan max_range must be in (0, " + fmt(max_range_limit) + "] m at resolution " +
                     fmt(config_.resolution) + ", got " + fmt(scan.max_range) + "; scan skipped";
    return result;
  }
  octomap::point3d origin(scan.origin.x, scan.origin.y, scan.origin.z);
  if (config_.dimensions == 2) origin.z() = static_cast<float>(config_.slab_z);
  octomap::OcTreeKey origin_key;
  // OctoMap's 16-bit keys span +-32768 voxels. Bounded here before coordToKeyChecked, which converts
  // coordinate / resolution to int before it checks the range (undefined for |coordinate| >= 2^31 voxels).
  const double half_extent = 32768.0 * config_.resolution;
  const auto inMap = [half_extent](float v) { return std::isfinite(v) && std::fabs(v) < half_extent; };
  if (!inMap(origin.x()) || !inMap(origin.y()) || !inMap(origin.z()) || !tree.coordToKeyChecked(origin, origin_key)) {
    result.message = "scan sensor origin (" + fmt(scan.origin.x) + ", " + fmt(scan.origin.y) + ", " +
                     fmt(scan.origin.z) + ") is not finite or outside the map (|coordinate| < " +
                     fmt(half_extent) + " m); scan skipped";
    return result;
  }
  if (scan.points.size() > config_.max_points) {
    result.message = "scan has " + std::to_string(scan.points.size()) + " points, more than max_points = " +
                     std::to_string(config_.max_points) + "; scan skipped";
    return result;
  }

  std::vector<octomap::point3d>& cleaned = impl_->cleaned;
  std::vector<bool>& beside_invalid = impl_->beside_invalid;
  cleaned.clear();
  beside_invalid.clear();
  cleaned.reserve(scan.points.size());
  const float slab = static_cast<float>(config_.slab_z);
  bool after_invalid = false;
  for (const Point3f& p : scan.points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      ++result.dropped_non_finite;
      if (!beside_invalid.empty()) beside_invalid.back() = true;
      after_invalid = true;
      continue;
    }
    cleaned.emplace_back(p.x, p.y, config_.dimensions == 2 ? slab : p.z);
    beside_invalid.push_back(after_invalid);
    after_invalid = false;
  }
  if (after_invalid && !beside_invalid.empty()) beside_invalid.front() = true;  // a turn later: next to the first
  result.points_used = cleaned.size();
  if (result.dropped_non_finite > 0) {
    result.message = "dropped " + std::to_string(result.dropped_non_finite) + " non-finite points of " +
                     std::to_string(scan.points.size());
  }
  if (cleaned.empty()) {
    result.message += result.message.empty() ? "scan has no points; nothing inserted" : "; nothing inserted";
    result.inserted = true;  // a valid, empty scan
    return result;
  }

  impl_->gap_rays.clear();
  impl_->surface_fill.clear();
  if (config_.dimensions == 2 && (config_.clear_beam_gaps || config_.fill_surfaces_between_returns)) {
    const double step = sortedBeams(cleaned, beside_invalid, origin, impl_->beams, impl_->gaps);
    if (config_.clear_beam_gaps)  // at most as many rays as the scan had returns
      result.gap_rays = addBeamGapRays(impl_->beams, step, 0.0, origin, scan.max_range, config_.max_clear_gap_rad, cleaned.size(),
                                       impl_->gap_rays);
    if (config_.fill_surfaces_between_returns) {
      const double max_length = config_.max_surface_fill_m > 0.0 ? config_.max_surface_fill_m : scan.max_range / 8.0;
      // At most 8 points per return: a scan's whole fill stays within a few times its own work.
      result.surface_fill = addSurfaceFill(impl_->beams, step, origin, config_.resolution, 0.5 * config_.resolution, max_length,
                                           8 * cleaned.size(), impl_->surface_fill);
    }
  } else if (config_.dimensions == 3 && config_.clear_beam_gaps) {
    result.gap_rays = addRingGapRays(cleaned, beside_invalid, origin, scan.max_range, config_.max_clear_gap_rad, cleaned.size(),
                                     impl_->by_elevation, impl_->beams, impl_->gaps, impl_->gap_rays);
  }

  // One insertion: the scan's points cut at max_range, the surface fill's voxels marked occupied with no ray, and the
  // gap rays cleared to their ends (a voxel a return of this scan hit stays a hit: occupied wins, OctoMap's rule).
  const std::vector<octomap::point3d>* fill = impl_->surface_fill.empty() ? nullptr : &impl_->surface_fill;
  const std::vector<octomap::point3d>* clear_rays = impl_->gap_rays.empty() ? nullptr : &impl_->gap_rays;
  if (config_.method == InsertMethod::kFast) {
    const detail::InsertCounts counts = impl_->inserter.insert(tree, cleaned, origin, scan.max_range, config_.discretize,
                                                               config_.threads, config_.pipeline, fill, clear_rays,
                                                               config_.free_discovery_near_range_m);
    result.free_cells += counts.free_cells;
    result.occupied_cells += counts.occupied_cells;
    result.seconds_rays += counts.seconds_rays;
    result.seconds_merge += counts.seconds_merge;
    result.seconds_tree += counts.seconds_tree;
    result.seconds_wait += counts.seconds_wait;
    result.walk_threads = std::max(result.walk_threads, counts.walk_threads);
  } else {
    finish();
    impl_->region_exports.clear();  // this path reports no changed regions: nothing kept stays sure
    impl_->delayed_regions.clear();
    // The fill's voxels as they were before the scan (detail::fillUpdate decides on that; search finds a pruned
    // parent leaf too).
    std::vector<std::pair<octomap::OcTreeKey, std::optional<float>>> fill_before;
    if (fill != nullptr) {
      octomap::KeySet cells;
      octomap::OcTreeKey key;
      for (const octomap::point3d& p : *fill)
        if (tree.coordToKeyChecked(p, key)) cells.insert(key);
      for (const octomap::OcTreeKey& k : cells) {
        const octomap::OcTreeNode* n = tree.search(k);
        fill_before.emplace_back(k, n != nullptr ? std::optional(n->getLogOdds()) : std::nullopt);
      }
    }
    // OcTree::insertPointCloud's own steps (lazy_eval = false), with the gap rays' cells added to the free ones.
    octomap::Pointcloud cloud;
    cloud.reserve(cleaned.size());
    for (const octomap::point3d& p : cleaned) cloud.push_back(p);
    octomap::KeySet free_cells, occupied_cells;
    if (config_.discretize) tree.computeDiscreteUpdate(cloud, origin, free_cells, occupied_cells, scan.max_range);
    else tree.computeUpdate(cloud, origin, free_cells, occupied_cells, scan.max_range);
    if (clear_rays != nullptr) {
      octomap::KeyRay ray;
      for (const octomap::point3d& end : *clear_rays)
        if (tree.computeRayKeys(origin, end, ray))
          for (const octomap::OcTreeKey& k : ray)
            if (occupied_cells.count(k) == 0) free_cells.insert(k);
    }
    for (const octomap::OcTreeKey& k : free_cells) tree.updateNode(k, false, /*lazy_eval=*/false);
    for (const octomap::OcTreeKey& k : occupied_cells) tree.updateNode(k, true, /*lazy_eval=*/false);
    if (fill != nullptr) {
      for (const auto& [k, before] : fill_before) {
        if (occupied_cells.count(k) != 0) continue;  // a fill voxel with a return in it took a plain hit
        const octomap::OcTreeNode* after = tree.search(k);
        const bool crossed = after != nullptr && (!before || after->getLogOdds() != *before);
        if (detail::fillUpdate(before, crossed, tree.getProbMissLog()).value_or(false))
          tree.setNodeValue(k, before.value_or(0.0f) + tree.getProbHitLog(), /*lazy_eval=*/false);
      }
    }
  }
  result.inserted = true;
  // kOctoMap does not report its cell counts; assume it changed something.
  changed_ = changed_ || config_.method == InsertMethod::kOctoMap || result.free_cells + result.occupied_cells > 0;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return result;
}


void OccupancyMapper::finish() const { impl_->inserter.finish(); }

ExportedMap OccupancyMapper::exportMap(bool complete) {
  finish();
  ExportedMap map;
  const octomap::OcTree& tree = impl_->tree;
  // Kept walks are good only while their regions' classes stand; the OctoMap method reports no regions, so
  // insert() dropped them all then. A region of open air where unknown voxels were only observed free keeps its walk
  // for up to free_discovery_delay_exports exports (a moving lidar's sparse far rays find new free voxels in most
  // regions they cross on every scan, and each was walked again at every export); every other change of class is
  // exported at once.
  auto& delayed = impl_->delayed_regions;
  const std::uint64_t now = impl_->exports++;
  const std::vector<std::uint64_t> changed = impl_->inserter.takeChangedRegions();
  // A region with an occupied voxel, or beside one (a face neighbour) that has one or changed class otherwise now, is
  // near a mapped surface: its new free space is what a window's inside, the space under an overhang or a wall's
  // thickness seen through an opening are made of (the column rule yields to it: docs/world-model.md), and it goes out
  // at once, and so does a put-off region once such a change comes beside it. What is put off is open air.
  std::vector<std::uint64_t> other_change;
  for (std::uint64_t region : changed)
    if (!(region & detail::kFreeDiscoveryOnly)) other_change.push_back(region);  // sorted, as `changed` is
  const auto changedOtherwise = [&](std::uint64_t region) { return std::binary_search(other_change.begin(), other_change.end(), region); };
  const auto nearSurface = [&](std::uint64_t region, const RegionExport& kept) {
    if (kept.occupied_leaves > 0) return true;
    for (std::uint64_t neighbour : detail::faceNeighbourRegions(region)) {
      if (changedOtherwise(neighbour)) return true;
      const auto walked = impl_->region_exports.find(neighbour);
      if (walked != impl_->region_exports.end() && walked->second.occupied_leaves > 0) return true;
    }
    return false;
  };
  for (std::uint64_t region : changed) {  // before the other changes' walks are dropped: their counts are read
    if (!(region & detail::kFreeDiscoveryOnly)) continue;
    region &= ~detail::kFreeDiscoveryOnly;
    if (changedOtherwise(region)) continue;  // walked now
    const auto kept = impl_->region_exports.find(region);
    if (kept == impl_->region_exports.end()) continue;  // walked now anyway
    if (config_.free_discovery_delay_exports == 0 || nearSurface(region, kept->second)) impl_->region_exports.erase(kept);
    else delayed.emplace(region, now);  // keeps the first export that left it out
  }
  for (std::uint64_t region : other_change) {
    impl_->region_exports.erase(region);
    delayed.erase(region);
    for (std::uint64_t neighbour : detail::faceNeighbourRegions(region))
      if (delayed.erase(neighbour) > 0) impl_->region_exports.erase(neighbour);
  }
  for (auto it = delayed.begin(); it != delayed.end();) {
    if (complete || now - it->second >= static_cast<std::uint64_t>(config_.free_discovery_delay_exports)) {
      impl_->region_exports.erase(it->first);
      it = delayed.erase(it);
    } else {
      ++it;
    }
  }
  MaxLikelihoodExport walk(tree, &impl_->region_exports);
  walk.out.reserve(2 * tree.size());
  map.resolution = tree.getResolution();
  map.dimensions = config_.dimensions;
  if (const octomap::OcTreeNode* root = tree.getRoot()) {
    const int keys = 1 << tree.getTreeDepth();  // the root spans every key; key 2^(depth-1) is the coordinate 0
    walk.nodes = 1;
    if (tree.nodeHasChildren(root)) walk.walk(root, {0, 0, 0}, keys, /*root=*/true);
    else {
      walk.out = {0, 0};  // a root alone: OctoMap writes it with no children
      walk.leaf({0, 0, 0}, keys);
    }
    const int zero = keys / 2;
    for (int a = 0; a < 3; ++a) {
      map.bounds_min[a] = (walk.lo[a] - zero) * map.resolution;
      map.bounds_max[a] = (walk.hi[a] - zero) * map.resolution;
    }
  }
  std::ostringstream header(std::ios::out | std::ios::binary);
  writeOctreeHeader(tree, walk.nodes, header);
  const std::string head = header.str();
  map.octree_binary.reserve(head.size() + walk.out.size());
  map.octree_binary.assign(head.begin(), head.end());
  map.octree_binary.insert(map.octree_binary.end(), walk.out.begin(), walk.out.end());
  map.leaf_count = walk.leaves;
  changed_ = false;
  return map;
}

bool OccupancyMapper::changedSinceExport() const { return changed_ || !impl_->delayed_regions.empty(); }

void OccupancyMapper::writeBt(const std::string& path) const {
  finish();
  std::ofstream out(path, std::ios::binary);
  if (out) writeOctreeBinary(impl_->tree, out);
  if (!out || !out.flush()) {
    throw std::runtime_error("cannot write the octree to '" + path + "'");
  }
}

const octomap::OcTree& OccupancyMapper::octree() const {
  finish();
  return impl_->tree;
}

std::size_t OccupancyMapper::scratchMemoryUsage() const {
  return impl_->inserter.memoryUsage() + impl_->cleaned.capacity() * sizeof(octomap::point3d) + impl_->regionExportBytes();
}

std::size_t OccupancyMapper::memoryUsage() const {
  finish();
  return impl_->tree.memoryUsage() + scratchMemoryUsage();
}

}  // namespace ddsnav::mapper
