// ddsnav info: what a recording holds (topics, types, counts, rates, drops, chunks, truncation).
#include <ddsnav/record/info.hpp>

#include <CLI/CLI.hpp>

#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"Describe an MCAP recording."};
  std::string path;
  bool json = false;
  app.add_option("file", path, "recording (.mcap)")->required();
  app.add_flag("--json", json, "machine-readable output");
  CLI11_PARSE(app, argc, argv);
  try {
    ddsnav::record::McapReader file(path);
    const auto info = ddsnav::record::describeRecording(file);
    if (json)
      std::cout << info.dump(2) << '\n';
    else
      std::cout << ddsnav::record::formatRecordingInfo(info);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "ddsnav info: " << e.what() << '\n';
    return 1;
  }
}
