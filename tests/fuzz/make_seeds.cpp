// Writes the binary seeds of the fuzz corpus: one sample of every message type (cdr/), octrees as the
// mapper publishes them (octomap_world/) and small recordings (mcap/). The text seeds (scenarios, launch
// files, parameter files) are copied or written by scripts/fuzz --seeds. Usage: fuzz-make-seeds CORPUS_DIR
#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/mcap.hpp>

#include <octomap/OcTree.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

using namespace ddsnav;
namespace fs = std::filesystem;

void writeFile(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::vector<std::uint8_t> octree(bool three_d) {
  octomap::OcTree tree(0.2);
  for (int i = 0; i < 12; ++i) {
    const double z = three_d ? 0.2 * (i % 5) : 0.0;
    tree.updateNode(octomap::point3d(float(2 + 0.2 * i), float(3 - 0.1 * i), float(z)), true);
    tree.updateNode(octomap::point3d(float(1 + 0.2 * i), float(1), float(z)), false);
  }
  std::ostringstream s;
  tree.writeBinaryConst(s);
  const std::string bytes = s.str();
  return {bytes.begin(), bytes.end()};
}


msg::Header header() {
  msg::Header h;
  h.stamp_ns(1'000'000'000);
  h.frame_id("map");
  return h;
}

// Filled samples of the types components check on arrival; the other types get a default sample.
std::vector<std::vector<std::uint8_t>> filledSamples(const std::vector<std::uint8_t>& map_bytes) {
  msg::PointCloud cloud;
  cloud.header(header());
  cloud.xyz({1.f, 2.f, 0.f, 3.f, 4.f, 0.f, 5.f, 6.f, 0.f});
  msg::ObstacleArray obstacles;
  obstacles.header(header());
  obstacles.planar(true);
  msg::ObstacleEllipsoid e;
  e.id(1);
  e.centre().x(10);
  e.centre().y(12);
  e.semi_axes().x(1.5);
  e.semi_axes().y(0.5);
  e.orientation().w(1);
  e.probability_bound(0.99);
  e.point_count(40);
  obstacles.obstacles({e});
  msg::OccupancyMap map;
  map.header(header());
  map.resolution(0.2);
  map.octree(map_bytes);
  msg::PlanRequest request;
  request.header(header());
  request.request_id(3);
  request.start().x(1);
  request.goal().x(30);
  request.goal_radius(1.5);
  request.planner("gart");
  request.time_budget_s(1.0);
  msg::Path path;
  path.header(header());
  path.solved(true);
  path.states({request.start(), request.goal()});
  msg::ComponentStatus status;
  status.name("planner");
  status.state(msg::LifecycleState::LIFECYCLE_READY);
  status.ready(true);
  return {msg::serializeToBytes(cloud), msg::serializeToBytes(obstacles), msg::serializeToBytes(map), msg::serializeToBytes(request), msg::serializeToBytes(path), msg::serializeToBytes(status)};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  const fs::path corpus = argv[1];
  const auto map2 = octree(false), map3 = octree(true);
  {
    std::vector<std::uint8_t> in2{0}, in3{1};  // first byte: 2-D / 3-D (target_octomap_world.cpp)
    in2.insert(in2.end(), map2.begin(), map2.end());
    in3.insert(in3.end(), map3.begin(), map3.end());
    writeFile(corpus / "octomap_world" / "seed-2d.bin", in2);
    writeFile(corpus / "octomap_world" / "seed-3d.bin", in3);
  }

  // cdr/: the type index first (target_cdr.cpp), then the encoded sample.
  const auto& types = msg::all_type_supports();
  for (std::size_t i = 0; i < types.size(); ++i) {
    void* sample = types[i]->create();
    std::vector<std::uint8_t> bytes(types[i]->serialized_size(sample));
    bytes.resize(types[i]->serialize(sample, bytes.data(), bytes.size()));
    types[i]->destroy(sample);
    bytes.insert(bytes.begin(), std::uint8_t(i));
    std::string name(types[i]->name.substr(types[i]->name.rfind(':') + 1));
    writeFile(corpus / "cdr" / ("seed-" + name + "-default.bin"), bytes);
  }
  std::vector<std::vector<std::uint8_t>> filled = filledSamples(map2);
  const char* filled_names[] = {"PointCloud", "ObstacleArray", "OccupancyMap", "PlanRequest", "Path", "ComponentStatus"};
  for (std::size_t k = 0; k < filled.size(); ++k) {
    std::size_t index = 0;
    while (types[index]->name != std::string("ddsnav::msg::") + filled_names[k]) ++index;
    filled[k].insert(filled[k].begin(), std::uint8_t(index));
    writeFile(corpus / "cdr" / ("seed-" + std::string(filled_names[k]) + ".bin"), filled[k]);
  }

  // mcap/: the same samples recorded, uncompressed and zstd, closed and (a crash) unclosed.
  fs::create_directories(corpus / "mcap");
  for (const auto compression : {record::Compression::None, record::Compression::Zstd}) {
    for (const bool closed : {true, false}) {
      const fs::path path = corpus / "mcap" /
                            (std::string("seed-") + (compression == record::Compression::Zstd ? "zstd" : "plain") +
                             (closed ? "" : "-unclosed") + ".mcap");
      const std::string full = path.string() + ".full";
      record::McapWriter writer(full, {.compression = compression, .chunk_size = 512});
      const char* topics[] = {"sensors/points", "perception/obstacles", "map/octomap", "planning/request", "planning/path", "system/status"};
      for (std::size_t k = 0; k < filled.size(); ++k) {
        const std::string type = std::string("ddsnav::msg::") + filled_names[k];
        const auto schema = writer.addSchema(type, "omgidl", "struct " + std::string(filled_names[k]) + " {};");
        const auto channel = writer.addChannel(schema, topics[k], "cdr", {{"keyed", k == 5 ? "true" : "false"}});
        const std::span<const std::uint8_t> payload(filled[k].data() + 1, filled[k].size() - 1);
        writer.write(channel, 1000 + k, 900 + k, payload);
        writer.write(channel, 2000 + k, 1900 + k, payload);
      }
      writer.addMetadata("ddsnav", {{"seed", "fuzz"}});
      writer.flush();
      // Unclosed: the file as a crashed recorder leaves it (chunks on disk, no summary, no footer).
      if (!closed) fs::copy_file(full, path, fs::copy_options::overwrite_existing);
      writer.close();
      if (closed) fs::rename(full, path);
      else fs::remove(full);
    }
  }
  std::printf("seeds written to %s\n", corpus.c_str());
  return 0;
}
