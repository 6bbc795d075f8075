// Shared by the fuzz targets: the input as text or as a scratch file, and the one rule every target
// checks — an error message names where the bad input came from (conventions: "one clear message that
// names the file").
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include <unistd.h>

namespace ddsnav::fuzz {

inline std::string text(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// Readers that take a path get the input through a scratch file, one per process (libFuzzer runs the
// target in one process; -fork/-jobs workers are separate processes).
class ScratchFile {
 public:
  ScratchFile(const std::uint8_t* data, std::size_t size, std::string_view suffix) {
    const char* dir = std::getenv("TMPDIR");
    path_ = std::string(dir && *dir ? dir : "/tmp") + "/ddsnav-fuzz-" + std::to_string(::getpid()) + std::string(suffix);
    std::FILE* f = std::fopen(path_.c_str(), "wb");
    if (f == nullptr || (size > 0 && std::fwrite(data, 1, size, f) != size)) {
      std::perror(path_.c_str());
      std::abort();  // the harness itself is broken, not the code under test
    }
    std::fclose(f);
  }
  ~ScratchFile() { std::remove(path_.c_str()); }
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Aborts (a finding) when an error message does not name its source. what() is a C string: a name holding a
// NUL byte can only appear up to it.
inline void expectNamed(std::string_view message, std::string_view source) {
  source = source.substr(0, source.find('\0'));
  if (message.find(source) == std::string_view::npos) {
    std::fprintf(stderr, "error message does not name '%.*s': %.*s\n", int(source.size()), source.data(),
                 int(message.size()), message.data());
    std::abort();
  }
}

}  // namespace ddsnav::fuzz
