#pragma once
// Small helpers the nodes' benchmark executables share (bench-roundtrip, bench-busy, bench-mission).

#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

namespace ddsnav::bench {

// The folder of the running executable: the component programs a benchmark starts sit beside it.
inline std::string binDir() {
  char buffer[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buffer, sizeof buffer - 1);
  if (n <= 0) return ".";
  const std::string path(buffer, static_cast<std::size_t>(n));
  return path.substr(0, path.rfind('/'));
}

// The p-quantile (0..1) of `v` by the nearest rank; 0 for an empty set.
inline double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5))];
}

}  // namespace ddsnav::bench
