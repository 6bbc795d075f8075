// Fuzz target, differential: the mapper's fast insertion against OctoMap's own OcTree::insertPointCloud on the
// same scans. The fast path re-implements OctoMap's ray walk with Morton-coded keys, marks into brick bitmaps,
// updates whole bricks as one node and splits the tree walk between threads; every one of those must leave
// exactly OctoMap's tree, on any resolution, range limit, map edge and thread count.
//
// Input: byte 0 flags (bit 0 discretize, bits 1-2 threads {1, 2, 3, 2}, bit 3 pipeline, bit 4 2-D, bit 5 a
// dense lidar-like fan of rays instead of explicit points, bits 6-7 scans - 1); byte 1 resolution (bits 0-2)
// and coordinate scale (bits 3-5); byte 2 max_range (bits 0-2), bit 3 the 2-D surface fill, bit 4 the beam-gap
// rays, 2-D or per ring in 3-D (the fan's 24 rings) (fill_surfaces_between_returns, clear_beam_gaps: the reference
// is then the kOctoMap method's own fill and gap rays, in OctoMap's computeUpdate); then int16 triplets: per scan
// its origin, then its points (explicit mode) or, in fan mode, the bytes that set the fan's ranges.
// Contract: both mappers accept or refuse the same scans, and their trees are byte-identical (OcTree::write:
// structure and every log-odds) after every scan.
#include <ddsnav/mapper/occupancy_mapper.hpp>
#include <octomap/OcTree.h>

#include "../../mapper/tests/mapper_test_util.hpp"  // fullBytes: the tree as OcTree::write bytes

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <vector>

namespace {

using ddsnav::mapper::InsertMethod;
using ddsnav::mapper::MapperConfig;
using ddsnav::mapper::OccupancyMapper;
using ddsnav::mapper::Point3f;
using ddsnav::mapper::Scan;
using ddsnav::mapper::testing::fullBytes;

class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool has(std::size_t n) const { return pos_ + n <= size_; }
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  std::int16_t int16() {
    std::int16_t v = 0;
    if (has(2)) std::memcpy(&v, data_ + pos_, 2);
    pos_ += 2;
    return v;
  }
  std::size_t left() const { return pos_ < size_ ? size_ - pos_ : 0; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3 + 6) return 0;
  Reader in(data, size);
  const std::uint8_t flags = in.byte();
  const std::uint8_t scale_byte = in.byte();
  const std::uint8_t range_byte = in.byte();
  static constexpr double kResolutions[8] = {0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 7.3};
  static constexpr float kScales[8] = {0.001f, 0.01f, 0.05f, 0.2f, 1.0f, 5.0f, 50.0f, 400.0f};
  static constexpr double kRanges[8] = {std::numeric_limits<double>::infinity(), 0.3, 1.0, 4.0, 10.0, 30.0, 100.0, 1e4};
  static constexpr int kThreads[4] = {1, 2, 3, 2};

  MapperConfig config;
  config.discretize = (flags & 1) != 0;
  config.threads = kThreads[(flags >> 1) & 3];
  config.pipeline = (flags & 8) != 0;
  config.dimensions = (flags & 16) != 0 ? 2 : 3;
  config.slab_z = 0.25;
  config.resolution = kResolutions[scale_byte & 7];
  config.fill_surfaces_between_returns = (range_byte & 8) != 0;
  config.clear_beam_gaps = (range_byte & 16) != 0;
  const float scale = kScales[(scale_byte >> 3) & 7];
  const double max_range = kRanges[range_byte & 7];
  const bool fan = (flags & 32) != 0;
  const int scans = 1 + (flags >> 6);

  MapperConfig reference_config = config;
  reference_config.method = InsertMethod::kOctoMap;
  OccupancyMapper fast(config), reference(reference_config);

  double ray_voxels = 0.0;
  const std::size_t triplets = in.left() / 6;
  const std::size_t per_scan = std::max<std::size_t>(1, triplets / scans);
  for (int s = 0; s < scans && in.has(6); ++s) {
    Scan scan;
    scan.max_range = max_range;
    scan.origin = {in.int16() * scale, in.int16() * scale, in.int16() * scale};
    if (fan) {
      // A 24 x 96 fan (elevation -40..+40 deg, full turn) whose ranges cycle through the scan's bytes; at most
      // 48 voxels long, so one input stays fast while rays still overlap into whole bricks near the origin.
      std::vector<std::uint8_t> ranges;
      for (std::size_t i = 0; i + 1 < per_scan * 6 && in.has(1); ++i) ranges.push_back(in.byte());
      if (ranges.empty()) ranges.push_back(255);
      const float longest = static_cast<float>(48.0 * config.resolution);
      for (int ring = 0; ring < 24; ++ring) {
        const float elevation = (-40.0f + 80.0f * ring / 23.0f) * 3.14159265f / 180.0f;
        for (int column = 0; column < 96; ++column) {
          const float azimuth = column * 2.0f * 3.14159265f / 96.0f;
          const std::uint8_t r = ranges[(ring * 96 + column) % ranges.size()];
          const float range = longest * (0.05f + 0.95f * r / 255.0f);
          scan.points.push_back({scan.origin.x + range * std::cos(elevation) * std::cos(azimuth),
                                 scan.origin.y + range * std::cos(elevation) * std::sin(azimuth),
                                 scan.origin.z + range * std::sin(elevation)});
        }
      }
    } else {
      for (std::size_t i = 1; i < per_scan && in.has(6); ++i) {
        scan.points.push_back({in.int16() * scale, in.int16() * scale, in.int16() * scale});
      }
    }
    // Bounded work per input (libFuzzer's 10 s timeout, under ASan): at most ~600 k ray voxels over all scans;
    // the scans beyond are not inserted (a 0.05 m map with 1.6 km rays would otherwise take minutes in OctoMap's
    // reference insertion).
    for (const Point3f& p : scan.points) {
      const double dx = p.x - scan.origin.x, dy = p.y - scan.origin.y, dz = p.z - scan.origin.z;
      ray_voxels += std::min(std::sqrt(dx * dx + dy * dy + dz * dz), max_range) / config.resolution;
    }
    if (!(ray_voxels <= 6e5)) return 0;
    const auto a = fast.insert(scan);
    const auto b = reference.insert(scan);
    if (a.inserted != b.inserted) {
      std::fprintf(stderr, "scan %d: fast %s, OctoMap %s (%s / %s)\n", s, a.inserted ? "inserted" : "refused",
                   b.inserted ? "inserted" : "refused", a.message.c_str(), b.message.c_str());
      std::abort();
    }
    if (fullBytes(fast.octree()) != fullBytes(reference.octree())) {
      std::fprintf(stderr, "scan %d: the fast tree differs from OctoMap's (resolution %g, max_range %g, threads %d, "
                   "pipeline %d, discretize %d, %d-D, fill %d, gap rays %d, %zu points)\n", s, config.resolution, max_range,
                   config.threads, int(config.pipeline), int(config.discretize), config.dimensions,
                   int(config.fill_surfaces_between_returns), int(config.clear_beam_gaps), scan.points.size());
      std::abort();
    }
  }
  return 0;
}
