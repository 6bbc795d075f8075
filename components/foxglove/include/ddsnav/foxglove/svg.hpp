// A top-down SVG of foxglove.SceneUpdate messages: the newest state of every entity, drawn the way
// Foxglove's 3D panel shows it from above (cubes as turned rectangles, spheres and cylinders as turned
// ellipses, lines, arrows; labels of channels with at most 10 entities). For docs and quick looks at an export without opening Foxglove.
#pragma once

#include <nlohmann/json.hpp>

#include <map>
#include <string>

namespace ddsnav::foxglove {

class SceneSvg {
 public:
  // Applies one SceneUpdate of `channel` (deletions, then entities replacing those of the same id).
  void add(const std::string& channel, const nlohmann::json& scene_update);
  std::size_t entityCount() const;
  // The picture, width_px wide, scaled to everything drawn; a title line at the top.
  std::string render(const std::string& title, double width_px = 900) const;

 private:
  std::map<std::string, std::map<std::string, nlohmann::json>> entities_;  // channel -> id -> entity
};

}  // namespace ddsnav::foxglove
