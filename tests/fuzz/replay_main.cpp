// Runs every file given (or found under a given directory) through LLVMFuzzerTestOneInput once, without
// libFuzzer: the normal build replays the checked-in corpus of each fuzz target as an ordinary ctest test,
// so every input that once crashed stays fixed, with gcc and without a fuzzing toolchain.
//
// The fuzzers' limits hold here too, so an input that once allocated without bound or ran for ever fails the
// plain build as well: the address space is capped at 2 GB (std::bad_alloc escapes the target and ends the
// process; not under a sanitizer, whose shadow memory needs terabytes of address space) and each input gets
// a few seconds (alarm): every corpus input runs in milliseconds once its bug is fixed.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <csignal>
#include <cstring>

#include <sys/resource.h>
#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

#ifdef DDSNAV_SANITIZED  // top-level CMakeLists.txt: the ASan / TSan builds (scripts/fuzz builds in build-asan)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif

constexpr rlim_t kAddressSpaceLimit = rlim_t(2) << 30;   // scripts/fuzz: -rss_limit_mb=2048
constexpr unsigned kSecondsPerInput = kSanitized ? 15 : 3;  // scripts/fuzz: -timeout=10 under ASan

char current_input[4096];

void onAlarm(int) {
  const char* what = "fuzz replay: input takes too long (a hang): ";
  (void)!write(2, what, std::strlen(what));
  (void)!write(2, current_input, std::strlen(current_input));
  (void)!write(2, "\n", 1);
  std::abort();
}

std::vector<std::filesystem::path> inputs(int argc, char** argv) {
  std::vector<std::filesystem::path> files;
  for (int i = 1; i < argc; ++i) {
    const std::filesystem::path arg = argv[i];
    if (std::filesystem::is_directory(arg)) {
      for (const auto& entry : std::filesystem::recursive_directory_iterator(arg))
        if (entry.is_regular_file()) files.push_back(entry.path());
    } else {
      files.push_back(arg);
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s FILE_OR_DIR...\n", argv[0]);
    return 2;
  }
  if (!kSanitized) {
    const rlimit limit{kAddressSpaceLimit, kAddressSpaceLimit};
    setrlimit(RLIMIT_AS, &limit);
  }
  std::signal(SIGALRM, onAlarm);
  const auto files = inputs(argc, argv);
  if (files.empty()) {
    std::fprintf(stderr, "%s: no inputs found\n", argv[0]);
    return 2;
  }
  for (const auto& file : files) {
    std::ifstream in(file, std::ios::binary);
    if (!in) {
      std::fprintf(stderr, "cannot read %s\n", file.c_str());
      return 2;
    }
    const std::vector<std::uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    std::fprintf(stderr, "replaying %s (%zu bytes)\n", file.c_str(), bytes.size());
    std::snprintf(current_input, sizeof current_input, "%s", file.c_str());
    alarm(kSecondsPerInput);
    LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
    alarm(0);
  }
  std::printf("%zu input(s) replayed\n", files.size());
  return 0;
}
