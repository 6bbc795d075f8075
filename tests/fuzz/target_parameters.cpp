// Fuzz target: a component's parameters — a --config YAML file plus one `--param key=value` override
// (the input's first line) — read back as every parameter type the components declare.
// Contract: ParameterError (naming the parameter or the file), never another exception.
#include "fuzz_input.hpp"

#include <ddsnav/runtime/parameters.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace {

template <class T>
void tryDeclare(ddsnav::runtime::Parameters& p, const std::string& key) {
  try {
    (void)p.declare<T>(key, T{});
  } catch (const ddsnav::runtime::ParameterError& e) {
    ddsnav::fuzz::expectNamed(e.what(), key);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input = ddsnav::fuzz::text(data, size);
  const auto newline = input.find('\n');
  std::vector<std::string> overrides;
  if (newline != std::string::npos && newline > 0) overrides.push_back(input.substr(0, newline));
  const std::string yaml = newline == std::string::npos ? input : input.substr(newline + 1);
  const ddsnav::fuzz::ScratchFile file(reinterpret_cast<const std::uint8_t*>(yaml.data()), yaml.size(), ".yaml");
  ddsnav::runtime::Parameters params;
  try {
    params = ddsnav::runtime::Parameters::load(file.path(), overrides);
  } catch (const ddsnav::runtime::ParameterError&) {
    return 0;  // names the file or the --param; which one depends on the input
  }
  for (const auto& entry : params.sources()) {
    const std::string key = entry.first;
    tryDeclare<double>(params, key);
    tryDeclare<int>(params, key);
    tryDeclare<std::int64_t>(params, key);
    tryDeclare<bool>(params, key);
    tryDeclare<std::string>(params, key);
    tryDeclare<std::vector<double>>(params, key);
    tryDeclare<std::vector<std::string>>(params, key);
  }
  try {
    params.rejectUndeclared();
  } catch (const ddsnav::runtime::ParameterError&) {
    std::abort();  // every key was declared above
  }
  return 0;
}
