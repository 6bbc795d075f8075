// ddsnav export --foxglove IN.mcap OUT.mcap: a recording with Foxglove views added (docs/visualize.md).
#include <ddsnav/foxglove/export.hpp>

#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>

using namespace ddsnav;

int main(int argc, char** argv) {
  CLI::App app{"Copy a recording, adding derived channels in Foxglove's own schemas (foxglove.SceneUpdate, ...)."};
  bool foxglove = false;
  std::string in, out, scenario, svg;
  app.add_flag("--foxglove", foxglove, "add the Foxglove views (the only export there is; required)");
  app.add_option("input", in, "recording (.mcap)")->required()->check(CLI::ExistingFile);
  app.add_option("output", out, "new recording (.mcap)")->required();
  app.add_option("--scenario", scenario, "scenario file: its true obstacles on foxglove/scenario")->check(CLI::ExistingFile);
  app.add_option("--svg", svg, "also write the final scene seen from above as SVG");
  CLI11_PARSE(app, argc, argv);
  if (!foxglove) {
    std::fprintf(stderr, "ddsnav export: nothing to do: give --foxglove\n");
    return 2;
  }
  std::error_code ec;
  if (std::filesystem::equivalent(in, out, ec)) {
    std::fprintf(stderr, "ddsnav export: %s is the input; write to another file\n", out.c_str());
    return 2;
  }
  try {
    foxglove::SceneDeriverOptions options;
    if (!scenario.empty()) options.scenario = planner::loadScenario(scenario);
    record::McapReader reader(in);
    if (reader.truncated())
      std::fprintf(stderr, "ddsnav export: %s ends early at byte %llu (%s); exporting what is there\n", in.c_str(),
                   static_cast<unsigned long long>(reader.truncatedAt()), reader.truncationReason().c_str());
    record::McapWriterOptions mcap;
    mcap.library = "ddsnav-export";
    record::McapWriter writer(out, mcap);
    foxglove::SceneSvg picture;
    const auto stats = foxglove::exportFoxglove(reader, writer, std::move(options), svg.empty() ? nullptr : &picture);
    writer.close();
    if (!svg.empty()) {
      std::FILE* f = std::fopen(svg.c_str(), "w");
      const std::string text = picture.render(std::filesystem::path(in).filename().string() + ": final scene (foxglove/* channels, top view)");
      if (!f || std::fwrite(text.data(), 1, text.size(), f) != text.size() || std::fclose(f) != 0) {
        std::fprintf(stderr, "ddsnav export: cannot write %s\n", svg.c_str());
        return 1;
      }
    }
    std::uint64_t derived = 0;
    for (const auto& [topic, n] : stats.derived) {
      std::printf("%-36s %llu\n", topic.c_str(), static_cast<unsigned long long>(n));
      derived += n;
    }
    std::printf("%s: %llu recorded messages copied, %llu Foxglove messages added\n", out.c_str(),
                static_cast<unsigned long long>(stats.copied), static_cast<unsigned long long>(derived));
    if (stats.failed > 0) {
      std::fprintf(stderr, "ddsnav export: %llu message(s) had no Foxglove view; first:\n", static_cast<unsigned long long>(stats.failed));
      for (const auto& e : stats.first_errors) std::fprintf(stderr, "  %s\n", e.c_str());
    }
    if (derived == 0) {
      std::fprintf(stderr, "ddsnav export: %s has no topic with a Foxglove view (clouds, obstacles, paths, vehicle, map)\n", in.c_str());
      return 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddsnav export: %s\n", e.what());
    return 1;
  }
  return 0;
}
