// For the tests that run a tool binary on a recording they write (ddsnav resmooth, ddsnav-replan-replay): the
// command's exit status and output, a sample's CDR bytes for the recording, and the scenario they replay it in.
#pragma once

#include <ddsnav/msg/messages.hpp>

#include <sys/wait.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace ddsnav::testing {

// An empty 40 x 40 m 2-D yard with a unicycle vehicle, from (2, 2) to (35, 30).
inline constexpr const char* kOpenYard2d =
    "name: open\ndimensions: 2\nbounds: {min: [0, 0], max: [40, 40]}\nrobot_radius: 0.5\n"
    "start: [2, 2]\ngoal: [35, 30]\ngoal_radius: 1\n"
    "vehicle: {model: unicycle, v_max: 2.0, omega_max: 1.0, dt: 0.1}\nobstacles: []\n";

struct ToolRun {
  int status = -1;  // the exit status; -1 when it did not exit normally or could not be started
  std::string out;  // stdout and stderr
};

inline ToolRun runTool(const std::string& command) {
  ToolRun r;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  char buffer[4096];
  while (std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) r.out.append(buffer, n);
  const int status = ::pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

template <class T>
std::vector<std::uint8_t> cdrBytesOf(const T& sample) {
  const auto& ts = msg::type_support<T>();
  std::vector<std::uint8_t> b(ts.serialized_size(&sample));
  b.resize(ts.serialize(&sample, b.data(), b.size()));
  return b;
}

}  // namespace ddsnav::testing
